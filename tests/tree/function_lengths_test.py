#!/usr/bin/env python3
"""No function in models/, report/ or cli/ is over 120 lines and no lambda in cli/ over 40 (a procedure
reads as its named steps; a command is a handler, not a callback: docs/architecture.md), no file in models/
over 800 lines and no class there over 250 (an engine file or class is read in one sitting), and the
scanner behind it (scripts/function_lengths.py) measures what it should."""
import pathlib
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(sys.argv.pop(1) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])
SCRIPT = ROOT / "scripts" / "function_lengths.py"


def run(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=120)


class FunctionLengths(unittest.TestCase):
    def test_models_report_and_cli_stay_below_the_bound(self):
        out = run("--max-lines", 120, ROOT / "models", ROOT / "report", ROOT / "cli")
        self.assertEqual(out.returncode, 0, "functions over 120 lines:\n" + out.stdout)

    def test_models_files_and_classes_stay_below_their_bounds(self):
        out = run("--max-file-lines", 800, "--max-class-lines", 250, ROOT / "models")
        self.assertEqual(out.returncode, 0, "files over 800 lines or classes over 250 in models/:\n" + out.stdout)

    def test_cli_handlers_are_functions_not_long_callbacks(self):
        out = run("--max-lambda-lines", 40, ROOT / "cli")
        self.assertEqual(out.returncode, 0, "lambdas over 40 lines:\n" + out.stdout)

    def test_the_scanner_measures_functions_lambdas_and_skips_text(self):
        source = "\n".join([
            "namespace a {",                       # 1
            "struct S {",                          # 2
            "  S() : x_{1}, y_(2) {",              # 3
            "    z_ = 3;",                         # 4
            "  }",                                 # 5
            "  int x_, y_, z_;",                   # 6
            "};",                                  # 7
            "// } a brace in a comment {",         # 8
            "int f(int v) {",                      # 9
            '  const char* s = "}{";',             # 10
            "  auto g = [&](int w) {",             # 11
            "    return w + v;",                   # 12
            "  };",                                # 13
            "  return g(v);",                      # 14
            "}",                                   # 15
            "constexpr int table[] = {1, 2, 3};",  # 16
            "}  // namespace a",                   # 17
            ""])
        with tempfile.TemporaryDirectory() as d:
            path = pathlib.Path(d) / "x.cpp"
            path.write_text(source)
            out = run("--lambdas", "--top", 10, path)
        lines = [l.split() for l in out.stdout.splitlines() if l.strip() and not l.endswith("longest 7")]
        found = {(row[2], row[1]): int(row[0]) for row in lines if len(row) >= 4}
        self.assertEqual(found.get(("S::S", "function")), 3, out.stdout)
        self.assertEqual(found.get(("f", "function")), 7, out.stdout)
        self.assertEqual(found.get(("lambda", "lambda")), 3, out.stdout)
        self.assertNotIn("table", out.stdout)


    def test_the_scanner_measures_a_class_with_its_members_and_a_file(self):
        header = "\n".join([
            "namespace a {",               # 1
            "template <class T>",          # 2
            "class C final : public B {",  # 3
            " public:",                    # 4
            "  int f() { return 1; }",     # 5
            "  int g();",                  # 6
            "  struct In { int x; };",     # 7
            "};",                          # 8
            "enum class E { one, two };",  # 9
            "}  // namespace a",           # 10
            ""])
        source = "\n".join([
            '#include "c.hpp"',  # 1
            "namespace a {",     # 2
            "int C::g() {",      # 3
            "  return 2;",       # 4
            "}",                 # 5
            "struct Local {",    # 6
            "  int y;",          # 7
            "};",                # 8
            "}  // namespace a", # 9
            ""])
        with tempfile.TemporaryDirectory() as d:
            (pathlib.Path(d) / "c.hpp").write_text(header)
            (pathlib.Path(d) / "c.cpp").write_text(source)
            listed = run("--classes", "--top", 10, d).stdout
            found = {row.split()[2]: int(row.split()[0]) for row in listed.splitlines() if row.strip()}
            self.assertEqual(found, {"C": 6 + 3, "C::In": 1, "Local": 3}, listed)  # the enum is no class
            over = run("--max-class-lines", 8, "--max-file-lines", 9, d)
            self.assertEqual(over.returncode, 1)
            self.assertIn("class C is 9 lines", over.stdout)
            self.assertIn("c.hpp: file is 10 lines", over.stdout)
            self.assertNotIn("c.cpp", over.stdout)


if __name__ == "__main__":
    unittest.main()
