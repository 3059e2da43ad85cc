#!/usr/bin/python3
"""guideway simulate dbb + guideway identify dbb --json, end to end through files.

usage: dbb_cli_test.py BUILD_DIR SOURCE_DIR
"""
import json
import os
import subprocess
import sys
import tempfile


def main():
    build, source = sys.argv[1], sys.argv[2]
    exe = os.path.join(build, "cli", "guideway")
    machine = os.path.join(source, "config", "machine-example.toml")
    with tempfile.TemporaryDirectory() as d:
        files = []
        for i, (r, h, direction) in enumerate([(95, 31.225, "ccw"), (95, 31.225, "cw"), (100, 0, "ccw")]):
            out = os.path.join(d, f"p{i}.csv")
            subprocess.run([exe, "simulate", "dbb", "--machine", machine, "--radius-mm", str(r), "--height-mm", str(h),
                            "--direction", direction, "--seed", str(10 + i), "--out", out], check=True,
                           stdout=subprocess.DEVNULL)
            files.append(out)
        res = subprocess.run([exe, "identify", "dbb", *files, "--json"], check=True, capture_output=True, text=True)
        j = json.loads(res.stdout)
        assert j["model"] == "lai3+ballbar", j["model"]
        assert len(j["runs"]) == 3
        for key in ("rms_um", "n", "condition_number", "unidentifiable"):
            assert key in j["fit"], key
        assert j["fit"]["n"] == 3 * 3601
        # the example machine: Lai e_x = -center_offset_x = -2 um, backlash 1 and 2 um
        ex = j["lai3"]["e_x_um"]
        assert abs(ex["value"] + 2.0) < 5 * ex["u"] + 0.05, ex
        assert abs(j["lai3"]["backlash_y_um"]["value"] - 2.0) < 0.1, j["lai3"]["backlash_y_um"]
        assert "c0_plus_d1_rad" in j["fit"]["unidentifiable"]
        for name, v in j["diagnostics"].items():
            assert "value" in v and v.get("u", 0) is not None, name
        # readable table and a clear error for a broken file
        text = subprocess.run([exe, "identify", "dbb", *files], check=True, capture_output=True, text=True).stdout
        assert "Lai's third-order model" in text and "not separable by these runs" in text, text
        assert "condition" not in text and "+/-" not in text and "fit:" not in text, text
        bad = os.path.join(d, "bad.csv")
        with open(files[2]) as f, open(bad, "w") as g:
            g.write(f.read().replace("# direction = ccw", "# direction = cw"))
        r = subprocess.run([exe, "identify", "dbb", bad], capture_output=True, text=True)
        assert r.returncode == 1 and "angles run counter-clockwise but the metadata says direction = cw" in r.stderr, r.stderr
    print("ok")


if __name__ == "__main__":
    main()
