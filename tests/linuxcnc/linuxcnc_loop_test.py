#!/usr/bin/python3
"""LinuxCNC in the loop (scripts/linuxcnc_loop.py, as scripts/linuxcnc_demo.sh runs it): LinuxCNC runs the program
`guideway program dbb` writes, the virtual machine follows its servo periods through guideway-linuxcnc-bridge,
guidewayd measures (the session begun and ended by the program's pin), `guideway compensate dbb` and
`guideway linuxcnc offsets` write the correction, LinuxCNC restarts with it and the same program runs again.

- G after < G before / 3 on the example machine (config/machine-example.toml);
- no servo period lost: the bridge's count and the stream a client recorded, without a gap or a notice;
- what LinuxCNC applied, period by period, is what the files say: x.comp and y.comp's correction (within the
  1 nm halsampler prints) and the external offsets of guideway-offsets.hal's lookups;
- the session's runs carry LinuxCNC's commanded position beside the bar's reading (x_cmd_mm, y_cmd_mm), paired by
  servo period: each row's the bridge's stream's command of the row's period less the drives' lag, to 1 nm.

At 3000 mm/min (the standard test's circles of 450 deg at r = 100 mm, 16 s each): about 100 s. Skipped (77)
with the reason printed where LinuxCNC cannot start (not installed, another LinuxCNC running, no user to run
it as).

usage: linuxcnc_loop_test.py BUILD_DIR SOURCE_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

SKIP = 77


def main():
    build, source = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory(prefix="guideway-loop-test-") as d:
        figures = os.path.join(d, "figures.json")
        res = subprocess.run([sys.executable, os.path.join(source, "scripts", "linuxcnc_loop.py"), "--bin-dir", build,
                              "--feed-mm-per-min", "3000", "--timeout-s", "300", "--json", figures],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=580)
        print(res.stdout)
        if res.returncode == SKIP:
            return SKIP
        assert res.returncode == 0, f"the loop failed (exit {res.returncode})"
        with open(figures) as f:
            j = json.load(f)
        assert all(j["checks"].values()), j["checks"]
        for name in ("before: stream without gaps", "after: bridge lost nothing", "x.comp applied as written",
                     "y.comp applied as written", "x's external offset applied as written",
                     "y's external offset applied as written", "before: runs carry LinuxCNC's commanded position of the reading's servo period",
                     "after: runs carry LinuxCNC's commanded position of the reading's servo period"):
            assert name in j["checks"], (name, sorted(j["checks"]))
        assert j["g_after_um"] < j["g_before_um"] / 3, (j["g_before_um"], j["g_after_um"])
        last = res.stdout.rstrip().splitlines()[-1]
        assert last.startswith("LinuxCNC loop: G before ") and last.endswith("(tables loaded by LinuxCNC)"), last
        print(f"G {j['g_before_um']:.2f} -> {j['g_after_um']:.2f} um ({j['g_after_um'] / j['g_before_um']:.0%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
