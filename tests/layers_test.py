#!/usr/bin/env python3
"""The layer check (scripts/check_layers.py) passes on the tree and catches an include that points up."""
import pathlib
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
CHECK = ROOT / "scripts" / "check_layers.py"


def run(root):
    return subprocess.run([sys.executable, str(CHECK), str(root)], capture_output=True, text=True, timeout=60)


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


if __name__ == "__main__":
    unittest.main()
