#!/usr/bin/python3
"""./scripts/plant_demo.sh as a newcomer runs it (issue 34): it exits 0; each machine's progress lines
name the machine; it prints what went over the broker itself (the retained status, PARAMS and EXPLAIN of
both machines) instead of a hint whose broker is gone; and the daemons, stopped before the broker, log
no lost connection. It builds the checkout's build/ and runs two daemons for about a minute: label slow.

usage: plant_demo_test.py SOURCE_DIR
"""
import os
import re
import subprocess
import sys
import tempfile


def main():
    source = sys.argv[1]
    with tempfile.TemporaryDirectory(prefix="gw-plant-demo-") as d:
        env = dict(os.environ, GUIDEWAY_PLANT_DIR=d, GUIDEWAY_PLANT_PORT=str(18900 + os.getpid() % 90))
        p = subprocess.run([os.path.join(source, "scripts", "plant_demo.sh")], cwd=source, env=env,
                           capture_output=True, text=True, timeout=900)
        out = p.stdout + p.stderr
        assert p.returncode == 0, out
        for machine in ("mill-1", "mill-2"):
            assert re.search(r"^   %s: \[\d+ s\] running: " % machine, out, re.M), out
            for leaf in ("status", "params/dbb", "explain/dbb"):
                assert re.search(r"^guideway/%s/%s \{" % (machine, leaf), out, re.M), (machine, leaf, out)
            log = open(os.path.join(d, machine + ".log")).read()
            assert not re.search(r"connection (was )?lost", log, re.I), log
        assert "Lai's three patterns" not in out, out  # the test is the standard one
    print("plant demo: ok")


if __name__ == "__main__":
    main()
