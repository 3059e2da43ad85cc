#!/usr/bin/python3
"""guideway map sequence on a live daemon (docs/map.md "On the daemon"): guidewayd with three emulated
autocollimators, each traversing one axis of the virtual machine (its stations over that axis' travel), and the
1-D artifacts of the same machine measured offline. Before any session the sequence lists every traverse as
not yet done and says what to run next; `--run` runs the three traverses one after the other on their devices,
each with its axis (the session's signs per axis), following each with its progress, then fits the map from
the daemon's latest traverse of each axis and the artifacts; afterwards every traverse reads as done. The map's
pitch and yaw of each axis come from its traverse and its artifact, and they agree (the cross-checks); without
a ballbar the squarenesses are said to be undetermined, with the test that would determine them.

usage: map_sequence_test.py GUIDEWAYD GUIDEWAY WORKDIR
"""
import json
import os
import shutil
import subprocess
import sys
import time

GUIDEWAYD, GUIDEWAY, WORK = sys.argv[1:4]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from process_support import Checks  # noqa: E402

check = Checks()
SOURCE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", ".."))
MACHINE = os.path.join(SOURCE, "config", "machine-example.toml")
TRAVEL = {"x": (-150, 150), "y": (-150, 150), "z": (-150, 150)}  # 4 stations each: a short test
STEP = 100

if os.path.exists(WORK):
    shutil.rmtree(WORK)
os.makedirs(WORK)

# Three autocollimators, one per axis, instead of the default's one along X.
default = subprocess.run([GUIDEWAYD, "--print-default-config"], capture_output=True, text=True, check=True).stdout
one = default.index('[[emulator]]\nname = "ac"')
end = default.index("[[emulator]]", one + 10)
block = default[one:end]
check('port = "{runtime_dir}/autocollimator.pty"' in block, "the default's autocollimator block changed")
three = ""
for axis, (lo, hi) in TRAVEL.items():
    three += ('[[emulator]]\nname = "ac-%s"\ninstrument = "autocollimator"\n'
              'args = ["--link", "{runtime_dir}/ac-%s.pty", "--axis", "%s", "--start-mm", "%d", "--end-mm", "%d", '
              '"--step-mm", "%d", "--dwell-s", "0.9", "--move-s", "0.3", "--return-s", "1.5"]\n\n'
              '[[device]]\nname = "ac-%s"\ndriver = "autocollimator-serial"\nport = "{runtime_dir}/ac-%s.pty"\n'
              'mode = "poll"\npoll_period_ms = 50\n\n') % (axis, axis, axis, lo, hi, STEP, axis, axis)
config = os.path.join(WORK, "map-day.toml")
with open(config, "w") as f:
    f.write(default[:one] + three + default[end:])

# The artifacts, measured offline on the same machine (the emulators' compiled-in one).
day = os.path.join(WORK, "offline")
subprocess.run([GUIDEWAY, "simulate", "day", "--machine", MACHINE, "--out-dir", day, "--planes", "", "--traverse", "",
                "--no-runout"], check=True, capture_output=True)
artifacts = [os.path.join(day, "artifact_" + a) for a in "xyz"]

sock = os.path.join(WORK, "g.sock")
env = {**os.environ, "XDG_STATE_HOME": os.path.join(WORK, "state")}
env.pop("NOTIFY_SOCKET", None)
log = open(os.path.join(WORK, "guidewayd.log"), "w+")
daemon = subprocess.Popen([GUIDEWAYD, "--config", config, "--socket", sock], env=env, stdout=log,
                          stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)


def gw(*args, timeout=240):
    return subprocess.run([GUIDEWAY, "--socket", sock, *args], capture_output=True, text=True, timeout=timeout)


try:
    deadline = time.monotonic() + 30
    while not os.path.exists(sock):
        if time.monotonic() > deadline or daemon.poll() is not None:
            raise SystemExit("guidewayd did not start:\n" + open(log.name).read())
        time.sleep(0.1)
    options = ["--no-ballbar", "--no-runout", "--traverse-devices", "ac-x", "ac-y", "ac-z", "--travel-mm",
               *[str(v) for lo_hi in TRAVEL.values() for v in lo_hi], "--traverse-step-mm", str(STEP)]
    before = gw("map", "sequence", *options)
    check(before.returncode == 0, "sequence before: %s" % before.stderr)
    for axis in "XYZ":
        check("autocollimator traverse of %s (its pitch and yaw): not yet" % axis in before.stdout,
              "before: the traverse of %s is not yet done:\n%s" % (axis, before.stdout))
    check("run: guideway start straightness --set axis=x" in before.stdout and "--device ac-x" in before.stdout,
          "before: the next test and how to run it:\n" + before.stdout)
    check("no test done yet" in before.stdout, "before: nothing to fit yet:\n" + before.stdout)

    out = os.path.join(WORK, "map.json")
    t0 = time.monotonic()
    ran = gw("map", "sequence", *options, "--run", "--artifact", *artifacts, "--out", out, "--timeout", "120")
    print("sequence --run took %.0f s" % (time.monotonic() - t0))
    check(ran.returncode == 0, "sequence --run: %s\n%s" % (ran.stderr[-2000:], ran.stdout[-2000:]))
    for k, axis in enumerate("XYZ"):
        check("test %d of 3: autocollimator traverse of %s" % (k + 1, axis) in ran.stdout,
              "--run: the traverse of %s in its turn:\n%s" % (axis, ran.stdout))
    check("running" in ran.stderr or "stations" in ran.stderr, "--run: the sessions' progress on stderr:\n" + ran.stderr)
    m = json.load(open(out))
    functions = {f["name"]: f for f in m["functions"]}
    for name, by in (("EBX", "traverse X + artifact X"), ("ECY", "traverse Y + artifact Y"),
                     ("EAZ", "traverse Z + artifact Z"), ("EXX", "artifact X"), ("EBY", "artifact Y")):
        check(functions[name]["determined"] and functions[name]["determined_by"] == by,
              "%s from %s: %s" % (name, by, functions[name]))
    for q in m["squareness"]:
        check(not q["determined"] and "no ballbar test in the %s plane" % q["plane"] in q["why"],
              "squareness %s: %s" % (q["plane"], q))
    angle_checks = [c for c in m["checks"] if c["first"].startswith("traverse")]
    check(len(angle_checks) == 6, "pitch and yaw of each axis compared: %d" % len(angle_checks))
    for c in angle_checks:
        check(c["consistent"], "live traverse against the artifact: %s" % c)

    after = gw("map", "sequence", *options)
    for axis in "XYZ":
        check("autocollimator traverse of %s (its pitch and yaw): done (session" % axis in after.stdout,
              "after: the traverse of %s is done:\n%s" % (axis, after.stdout))
    check("every test of the sequence is done" in after.stdout, "after: nothing left:\n" + after.stdout)
finally:
    daemon.terminate()
    daemon.wait(timeout=20)
    log.close()

sys.exit(check.finish("map_sequence_test: the map's tests on the daemon, guided"))
