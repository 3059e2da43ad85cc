#!/usr/bin/python3
"""What one ctest run did, from its JUnit file (ctest --output-junit): tests run, passed, failed and
skipped, and inside the tests that ran, the cases (GoogleTest's, unittest's) that were skipped, each
with its reason, so that a skip is never counted as a pass without being said.

usage: test_summary.py STAGE JUNIT.xml
Prints the stage's lines, then a last line `COUNTS passed failed skipped cases_run cases_skipped` for
scripts/test.sh to add up."""
import collections
import re
import sys
import xml.etree.ElementTree as ET

GTEST_SKIPPED = re.compile(r"^(?P<file>\S+:\d+): Skipped\n(?P<reason>.*?)\n*\[  SKIPPED \] (?P<case>\S+)", re.M | re.S)
GTEST_RAN = re.compile(r"^\[ +(OK|FAILED|SKIPPED) +\] (\S+) \(\d+ ms\)$", re.M)
UNITTEST_SKIP = re.compile(r"^(test\w*) \(([\w.]+)\) \.\.\. (?:[^\n]*?)skipped '(.*)'$", re.M)
UNITTEST_RAN = re.compile(r"^Ran (\d+) tests? in ", re.M)


def cases(output):
    """(cases run, [(case, reason)] skipped) in one test's output."""
    skipped = [(m.group("case"), " ".join(m.group("reason").split())) for m in GTEST_SKIPPED.finditer(output)]
    ran = sum(1 for m in GTEST_RAN.finditer(output) if m.group(1) != "SKIPPED")
    skipped += [(f"{m.group(2).split('.')[-2]}.{m.group(1)}", m.group(3)) for m in UNITTEST_SKIP.finditer(output)]
    unittest_total = sum(int(m.group(1)) for m in UNITTEST_RAN.finditer(output))
    ran += max(0, unittest_total - sum(1 for m in UNITTEST_SKIP.finditer(output)))
    return ran, skipped


def main():
    stage, path = sys.argv[1], sys.argv[2]
    root = ET.parse(path).getroot()
    passed = failed = skipped = cases_run = 0
    skipped_tests = []
    skipped_cases = collections.defaultdict(list)  # reason -> [test: case]
    for tc in root.iter("testcase"):
        name = tc.get("name")
        status = tc.get("status", "run")
        out = tc.find("system-out")
        output = out.text if out is not None and out.text else ""
        if status in ("notrun", "disabled") or tc.find("skipped") is not None:
            skipped += 1
            why = tc.find("skipped")
            reason = (why.get("message") if why is not None else "") or ""
            m = re.search(r"skipped[:, ]+(.*)", output)
            skipped_tests.append((name, reason or (m.group(1).strip() if m else "not run")))
            continue
        if tc.find("failure") is not None or tc.find("error") is not None or status == "fail":
            failed += 1
        else:
            passed += 1
        ran, skips = cases(output)
        cases_run += max(ran, 1)
        for case, reason in skips:
            skipped_cases[reason].append(f"{name}: {case}")
    n_case_skips = sum(len(v) for v in skipped_cases.values())
    print(f"== {stage}: {passed + failed} tests ran: {passed} passed, {failed} failed; {skipped} not run"
          f"; inside them {cases_run} cases ran, {n_case_skips} skipped")
    for name, reason in skipped_tests:
        print(f"   not run: {name}: {reason}")
    for reason, where in sorted(skipped_cases.items(), key=lambda kv: -len(kv[1])):
        shown = ", ".join(where[:3]) + (f" and {len(where) - 3} more" if len(where) > 3 else "")
        print(f"   skipped ({len(where)}): {reason}  [{shown}]")
    print(f"COUNTS {passed} {failed} {skipped} {cases_run} {n_case_skips}")


if __name__ == "__main__":
    main()
