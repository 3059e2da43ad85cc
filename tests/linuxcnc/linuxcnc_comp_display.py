#!/usr/bin/python3
"""The DISPLAY program of tests/linuxcnc/linuxcnc_comp_test.py's LinuxCNC configuration: no window, LinuxCNC's own
`linuxcnc` Python module (NML status, command and error channels) and its `hal` module (the pins).

It takes the machine out of estop, homes every joint (no switches: HOME_SEARCH_VEL = 0), then makes the
moves of the plan one by one (MDI G1, one axis at a time) and, once the move has ended and the joint's
filtered correction has settled, reads the joint's HAL pins: pos-cmd (what the trajectory planner
commands), motor-pos-cmd (what goes to the drive) and motor-offset (set by homing). The correction
LinuxCNC applies is motor-pos-cmd - pos-cmd - motor-offset. It writes them, and every message of the
error channel, to [GUIDEWAY_TEST]RESULT as JSON; when it exits, LinuxCNC shuts down.

The plan ([GUIDEWAY_TEST]PLAN, JSON): {"moves": [{"axis": "X", "joint": 0, "to_mm": 12.3}, ...]}.
"""
import json
import os
import sys
import time

import hal
import linuxcnc

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "linuxcnc"))
from guideway_headless import Machine  # noqa: E402

TIMEOUT_S = 20.0


def ini_path():
    args = sys.argv[1:]
    return args[args.index("-ini") + 1]


class Session(Machine):
    """linuxcnc/guideway_headless.py's machine (estop, on, homing, modes, the error channel), with MDI moves."""

    def __init__(self):
        super().__init__(echo=False)  # the test reads the messages from the result

    def start(self, joints):
        super().start()
        self.set_mode(linuxcnc.MODE_MDI)
        self.mdi("G21 G90 G94")

    def mdi(self, line):
        self.command.mdi(line)
        if self.command.wait_complete(TIMEOUT_S) == -1:
            raise RuntimeError(f"MDI '{line}' did not complete; LinuxCNC said: {self.messages}")
        self.wait_for(f"'{line}' done", lambda s: s.interp_state == linuxcnc.INTERP_IDLE and s.inpos)


def getp(pin):
    return float(hal.get_value(pin))  # full double precision (halcmd getp prints 7 digits)


def settled_pins(joint):
    """The joint's pins once the correction has stopped moving (LinuxCNC slews it after a reversal)."""
    names = ("pos-cmd", "motor-pos-cmd", "motor-offset")
    last = None
    for _ in range(200):
        now = {n: getp(f"joint.{joint}.{n}") for n in names}
        if last is not None and all(now[n] == last[n] for n in names):
            return now
        last = now
        time.sleep(0.02)
    raise RuntimeError(f"joint {joint}'s motor-pos-cmd did not settle: {last}")


def main():
    ini = linuxcnc.ini(ini_path())
    result_path = ini.find("GUIDEWAY_TEST", "RESULT")
    with open(ini.find("GUIDEWAY_TEST", "PLAN")) as f:
        plan = json.load(f)
    out = {"samples": [], "messages": [], "error": None}
    session = None
    try:
        session = Session()
        reader = hal.component("guideway_comp_check")  # hal.get_value needs the process to be a HAL component
        reader.ready()
        session.start(int(ini.find("KINS", "JOINTS")))
        for move in plan["moves"]:
            session.mdi(f"G1 {move['axis']}{move['to_mm']:.6f} F{plan.get('feed_mm_per_min', 3000)}")
            pins = settled_pins(move["joint"])
            out["samples"].append({**move, **pins})
        session.poll()
    except Exception as e:  # the test reports it with LinuxCNC's messages
        out["error"] = str(e)
    out["messages"] = session.messages if session else []
    with open(result_path, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
