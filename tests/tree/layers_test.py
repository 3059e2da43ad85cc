#!/usr/bin/env python3
"""The layer check (scripts/check_layers.py) passes on the tree and catches an include that points up."""
import pathlib
import re
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])
CHECK = ROOT / "scripts" / "check_layers.py"


def run(root, *options):
    return subprocess.run([sys.executable, str(CHECK), *options, str(root)], capture_output=True, text=True, timeout=60)


class Layers(unittest.TestCase):
    def test_the_tree_points_down(self):
        out = run(ROOT)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)

    def test_an_include_pointing_up_is_named_with_file_and_line(self):
        with tempfile.TemporaryDirectory() as d:
            tree = pathlib.Path(d)
            (tree / "models" / "dbb").mkdir(parents=True)
            (tree / "models" / "dbb" / "fine.cpp").write_text('#include "core/x.hpp"\n#include "formats/y.hpp"\n')
            out = run(tree)
            self.assertEqual(out.returncode, 0, out.stdout)
            (tree / "models" / "dbb" / "bad.cpp").write_text(
                '#include <vector>\n#include "models/dbb/a.hpp"\n#include "simulators/machine/machine.hpp"\n')
            (tree / "drivers").mkdir()
            (tree / "drivers" / "d.hpp").write_text('  #  include "daemon/daemon.hpp"\n')
            out = run(tree)
            self.assertEqual(out.returncode, 1)
            lines = out.stdout.splitlines()
            self.assertEqual(len(lines), 2, out.stdout)
            self.assertTrue(lines[0].startswith("drivers/d.hpp:1: drivers/ includes daemon/"), lines[0])
            self.assertTrue(lines[1].startswith("models/dbb/bad.cpp:3: models/ includes simulators/"), lines[1])
            self.assertIn("may include only core, dsp, formats", lines[1])

    def test_sessions_never_include_the_report(self):
        """Issue 43: the daemon, which builds a session's report, hands the report what the session identified
        (Session::identified_planes); a session does not fill the report's options itself."""
        with tempfile.TemporaryDirectory() as d:
            tree = pathlib.Path(d)
            (tree / "sessions").mkdir()
            (tree / "sessions" / "session.hpp").write_text('#include "models/explain/dbb_checked.hpp"\n')
            (tree / "daemon").mkdir()
            (tree / "daemon" / "session_manager.cpp").write_text('#include "report/report.hpp"\n')
            self.assertEqual(run(tree).returncode, 0, run(tree).stdout)
            (tree / "sessions" / "session.hpp").write_text('#include "report/report.hpp"\n')
            out = run(tree)
            self.assertEqual(out.returncode, 1)
            self.assertTrue(out.stdout.startswith("sessions/session.hpp:1: sessions/ includes report/"), out.stdout)

    def test_the_arrows_and_floors_of_the_tree(self):
        out = run(ROOT, "--arrows")
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        floor, reach = {}, {}
        for line in out.stdout.splitlines()[:-1]:
            level, layer, targets = re.fullmatch(r"floor (\d+)  (\w+)/ -> (.*)", line).groups()
            floor[layer] = int(level)
            reach[layer] = set() if targets == "nothing" else {t.split()[0] for t in targets.split(", ")}
        self.assertEqual(floor["core"], 0)
        self.assertNotIn("report", reach["sessions"])
        self.assertIn("sessions", reach["daemon"])
        self.assertIn("report", reach["daemon"])  # the daemon builds the session's report
        self.assertLessEqual(floor["sessions"], floor["report"], "sessions/ sits no higher than report/")
        for layer, targets in reach.items():
            for t in targets:
                self.assertLess(floor[t], floor[layer], f"{layer}/ -> {t}/ points down")
        self.assertRegex(out.stdout.splitlines()[-1], r"^\d+ arrows, \d+ floors$")


if __name__ == "__main__":
    unittest.main()
