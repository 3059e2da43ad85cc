#!/usr/bin/env python3
"""Every file says its job in its first lines: a header after `#pragma once`, a source file in its first
line (every folder of the tree, its tests and benchmarks too: issue 43 item 5).

Usage: purpose_lines_test.py [ROOT]
"""
import pathlib
import sys
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])
HEADER_FOLDERS = ("core", "dsp", "formats", "results", "models", "drivers", "plant", "report", "simulators",
                  "sessions", "fleet", "daemon", "cli", "tests", "bench")
# Every folder's .cpp files open with a purpose line too (issue 43 item 5: the 13 of the code, tests/, bench/).
SOURCE_FOLDERS = HEADER_FOLDERS


def opens_with_comment(line):
    return line.startswith("//") or line.startswith("/*")


class PurposeLines(unittest.TestCase):
    def test_every_header_says_its_job_after_pragma_once(self):
        for folder in HEADER_FOLDERS:
            for path in sorted((ROOT / folder).rglob("*.hpp")):
                lines = path.read_text().splitlines()
                self.assertGreaterEqual(len(lines), 2, path)
                self.assertEqual(lines[0], "#pragma once", path.relative_to(ROOT))
                self.assertTrue(opens_with_comment(lines[1]), f"{path.relative_to(ROOT)}:2: no purpose comment")

    def test_every_source_file_says_its_job_in_its_first_line(self):
        for folder in SOURCE_FOLDERS:
            sources = sorted((ROOT / folder).rglob("*.cpp"))
            self.assertTrue(sources, folder)
            for path in sources:
                first = path.read_text().split("\n", 1)[0]
                self.assertTrue(opens_with_comment(first) and len(first) > 10,
                                f"{path.relative_to(ROOT)}:1: no purpose line (a comment saying the file's job)")


if __name__ == "__main__":
    unittest.main()
