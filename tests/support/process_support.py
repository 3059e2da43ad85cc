"""Helpers shared by the tests that drive guidewayd and the emulators as processes."""
import subprocess
import time


def wait_for(predicate, timeout=10.0, poll_s=0.05):
    """Polls `predicate` until it returns something true or `timeout` seconds pass; returns its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(poll_s)
    return predicate()


class Checks:
    """Soft assertions for the end-to-end tests: check(cond, msg) prints and keeps each failure so one
    run reports them all; finish() prints the summary and gives the exit code."""

    def __init__(self):
        self.failures = []

    def __call__(self, cond, msg):
        if not cond:
            self.failures.append(msg)
            print("FAIL:", msg)

    def finish(self, passed):
        if self.failures:
            print("%d check(s) failed" % len(self.failures))
            return 1
        print(passed)
        return 0


def guideway_cli(guideway, socket_path, *args, timeout=30):
    """`guideway --socket SOCKET_PATH ARGS...`: its standard output, or AssertionError with its standard error."""
    out = subprocess.run([guideway, "--socket", socket_path, *args], capture_output=True, text=True, timeout=timeout)
    if out.returncode != 0:
        raise AssertionError(f"guideway {' '.join(args)}: {out.stderr}")
    return out.stdout


def run_unittests():
    """unittest.main for a test file run by ctest: exit 0 when all passed, 1 when any failed, and 77
    (the tests' SKIP_RETURN_CODE) when every case was skipped, so that ctest reports the test as not run
    instead of passed."""
    import sys
    import unittest
    result = unittest.main(verbosity=2, exit=False).result
    if not result.wasSuccessful():
        sys.exit(1)
    sys.exit(77 if result.testsRun > 0 and len(result.skipped) == result.testsRun else 0)
