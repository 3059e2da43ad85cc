#!/usr/bin/python3
"""Each test's time against its ctest timeout, from one stage's JUnit file: a test that takes more than a
third of its timeout leaves too little margin for a loaded machine (a warning), more than half fails the
stage. The timeouts are ctest's own (`ctest --show-only=json-v1`), so what is judged is what ctest enforces.

usage: test_margin.py STAGE BUILD_DIR JUNIT.xml
Prints the stage's margin lines; exit status 1 when a test took more than half its timeout."""
import json
import subprocess
import sys
import xml.etree.ElementTree as ET

WARN_SHARE = 1 / 3
FAIL_SHARE = 1 / 2
CTEST_DEFAULT_TIMEOUT_S = 1500.0  # ctest's own when a test sets none (DART_TESTING_TIMEOUT)


def timeouts(build_dir):
    """{test name: timeout in s} as ctest will enforce them."""
    out = subprocess.run(["ctest", "--test-dir", build_dir, "--show-only=json-v1"],
                         check=True, capture_output=True, text=True).stdout
    result = {}
    for test in json.loads(out).get("tests", []):
        props = {p["name"]: p["value"] for p in test.get("properties", [])}
        timeout = float(props.get("TIMEOUT", 0) or 0)
        result[test["name"]] = timeout if timeout > 0 else CTEST_DEFAULT_TIMEOUT_S
    return result


def durations(junit_path):
    """[(test name, seconds)] of the tests that ran."""
    root = ET.parse(junit_path).getroot()
    ran = []
    for tc in root.iter("testcase"):
        if tc.get("status", "run") in ("notrun", "disabled") or tc.find("skipped") is not None:
            continue
        ran.append((tc.get("name"), float(tc.get("time") or 0)))
    return ran


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    stage, build_dir, junit_path = sys.argv[1:]
    limits = timeouts(build_dir)
    rows = []
    for name, seconds in durations(junit_path):
        if name not in limits:
            continue
        rows.append((seconds / limits[name], name, seconds, limits[name]))
    rows.sort(reverse=True)
    over_half = [r for r in rows if r[0] > FAIL_SHARE]
    over_third = [r for r in rows if WARN_SHARE < r[0] <= FAIL_SHARE]
    worst = rows[0] if rows else None
    summary = f"== {stage} margin: {len(rows)} tests timed"
    if worst:
        summary += f", the tightest {worst[1]} {worst[2]:.1f} s of {worst[3]:.0f} s ({100 * worst[0]:.0f} %)"
    print(summary)
    for share, name, seconds, limit in over_half:
        print(f"   FAILED margin: {name} took {seconds:.1f} s, {100 * share:.0f} % of its {limit:.0f} s timeout "
              f"(more than half: a loaded machine would time it out)")
    for share, name, seconds, limit in over_third:
        print(f"   warning margin: {name} took {seconds:.1f} s, {100 * share:.0f} % of its {limit:.0f} s timeout "
              f"(more than a third)")
    sys.exit(1 if over_half else 0)


if __name__ == "__main__":
    main()
