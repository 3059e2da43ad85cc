"""Helpers shared by the tests that drive guidewayd and the emulators as processes."""
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
