#!/usr/bin/python3
"""A LinuxCNC DISPLAY program without a window: runs one G-code program and exits (docs/linuxcnc.md).

Named by the INI's [DISPLAY]DISPLAY; LinuxCNC starts it with `-ini INI` and shuts down when it exits. It
takes the machine out of estop, turns it on, homes every joint, opens [GUIDEWAY]PROGRAM in AUTO mode and
runs it. At an M0 (the program's stop to mount the ballbar) it waits [GUIDEWAY]MOUNT_S seconds, the
operator's part, and resumes. It prints its progress (line, the line's comment, the time) every few
seconds and every message of LinuxCNC's error channel, and writes [GUIDEWAY]RESULT (JSON: the seconds the
program ran, its messages, an error or null). Only LinuxCNC's own Python modules (linuxcnc).
"""
import json
import sys
import time

import linuxcnc

STEP_TIMEOUT_S = 30.0
PROGRESS_EVERY_S = 5.0


def say(text):
    print(f"guideway-headless: {text}", flush=True)


class Machine:
    """LinuxCNC's machine through its NML channels: estop, on, homing, modes, the error channel's messages
    (kept, and printed when `echo`)."""

    def __init__(self, echo=True):
        self.stat = linuxcnc.stat()
        self.command = linuxcnc.command()
        self.errors = linuxcnc.error_channel()
        self.messages = []
        self.echo = echo

    def poll(self):
        self.stat.poll()
        while True:
            e = self.errors.poll()
            if not e:
                return
            text = e[1].strip()
            self.messages.append(text)
            if self.echo:
                say(f"LinuxCNC says: {text}")

    def wait_for(self, what, predicate, timeout_s=STEP_TIMEOUT_S):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.poll()
            if predicate(self.stat):
                return
            time.sleep(0.01)
        raise RuntimeError(f"timed out after {timeout_s:.0f} s waiting for {what}")

    def set_mode(self, mode):
        self.command.mode(mode)
        self.command.wait_complete()
        self.wait_for(f"mode {mode}", lambda s: s.task_mode == mode)

    def start(self):
        self.wait_for("LinuxCNC's task", lambda s: s.task_state == linuxcnc.STATE_ESTOP)
        self.command.state(linuxcnc.STATE_ESTOP_RESET)
        self.command.wait_complete()
        self.command.state(linuxcnc.STATE_ON)
        self.command.wait_complete()
        self.wait_for("machine on", lambda s: s.task_state == linuxcnc.STATE_ON)
        self.set_mode(linuxcnc.MODE_MANUAL)
        self.command.teleop_enable(0)
        self.command.wait_complete()
        self.poll()
        for j in range(self.stat.joints):
            self.command.home(j)
            self.command.wait_complete()
            self.wait_for(f"joint {j} homed", lambda s, j=j: s.homed[j])
        if self.echo:
            say(f"machine on, {self.stat.joints} joints homed")


def comments(path):
    """Each line's comment (the text in parentheses), by line number, and the program's last move (a line of
    G0, G1, G2 or G3): a run that ends before it was cut short."""
    out, last_move = {}, None
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if "(" in line and ")" in line:
                out[number] = line[line.index("(") + 1:line.rindex(")")]
            if set(line.split("(")[0].upper().split()) & {"G0", "G1", "G2", "G3", "G00", "G01", "G02", "G03"}:
                last_move = number
    return out, last_move


def run_program(m, path, mount_s):
    notes, end_line = comments(path)
    m.set_mode(linuxcnc.MODE_AUTO)
    m.command.program_open(path)
    m.command.wait_complete()
    start = time.monotonic()
    m.command.auto(linuxcnc.AUTO_RUN, 0)
    m.command.wait_complete()
    m.wait_for("the program to start", lambda s: s.interp_state != linuxcnc.INTERP_IDLE)
    say(f"running {path}")
    last_said, reached = 0.0, 0
    while True:
        m.poll()
        s = m.stat
        now = time.monotonic() - start
        reached = max(reached, s.current_line, s.motion_line)
        if s.interp_state == linuxcnc.INTERP_IDLE:
            if end_line and reached < end_line:
                raise RuntimeError(f"the program stopped at line {reached} before its last move at line {end_line} "
                                   f"(LinuxCNC said: {m.messages or 'nothing'})")
            break
        if s.task_state != linuxcnc.STATE_ON:
            raise RuntimeError("the machine went off during the program")
        if s.interp_state == linuxcnc.INTERP_PAUSED or s.paused:
            say(f"[{now:.0f} s] line {s.motion_line}: stopped (M0): the operator mounts the bar ({mount_s:.1f} s)")
            time.sleep(mount_s)
            m.command.auto(linuxcnc.AUTO_RESUME)
            m.command.wait_complete()
            m.wait_for("the program to resume", lambda s: not s.paused and s.interp_state != linuxcnc.INTERP_PAUSED)
            continue
        if now - last_said >= PROGRESS_EVERY_S:
            last_said = now
            line = s.motion_line
            say(f"[{now:.0f} s] line {line}: {notes.get(line, '')}")
        time.sleep(0.02)
    return time.monotonic() - start


def main():
    args = sys.argv[1:]
    ini = linuxcnc.ini(args[args.index("-ini") + 1])
    result_path = ini.find("GUIDEWAY", "RESULT")
    out = {"seconds": None, "messages": [], "error": None}
    m = None
    try:
        m = Machine()
        m.start()
        out["seconds"] = run_program(m, ini.find("GUIDEWAY", "PROGRAM"), float(ini.find("GUIDEWAY", "MOUNT_S") or 1))
        m.poll()
        say(f"the program ended after {out['seconds']:.1f} s")
    except Exception as e:  # the loop reports it with LinuxCNC's messages
        out["error"] = str(e)
        say(f"ERROR: {e}")
    out["messages"] = m.messages if m else []
    if result_path:
        with open(result_path, "w") as f:
            json.dump(out, f)


if __name__ == "__main__":
    main()
