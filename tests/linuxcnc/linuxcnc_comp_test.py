#!/usr/bin/python3
"""LinuxCNC itself loads the tables `guideway compensate dbb` writes and applies our numbers, with our sign.

guideway simulate dbb (an XY pair and an XZ pair, on config/machine-leadscrew.toml with Z errors added:
scale errors, backlash on every axis, a 5 mm lead error on X) -> guideway compensate dbb --out-dir D ->
a headless LinuxCNC configuration around D's files (trivkins XYZ, a HAL with the joints looped back, the
[JOINT_n] lines of D/linuxcnc.ini added to the joints' sections as a user pastes them) ->
`linuxcnc -r CONFIG.ini`, whose DISPLAY is tests/linuxcnc/linuxcnc_comp_display.py: out of estop, home, MDI moves
of one axis at a time through positions between the table's lines (and one on a line), each reached once
moving up and once moving down, and after each the joint's pos-cmd, motor-pos-cmd and motor-offset pins.

- The correction LinuxCNC applies (motor-pos-cmd - pos-cmd - motor-offset) is what the table says there:
  nominal - forward after a move up, nominal - reverse after a move down, linear between lines
  (LinuxCNC's usrmotLoadComp, src/emc/motion/usrmotintf.cc, and its motion controller), and LinuxCNC
  says nothing about the tables.
- Our sign: with that correction the virtual machine's axes (their errors from the machine file) end where
  the program said, from either side, about a constant (a DBB sees no offset).
- What LinuxCNC does with a damaged table: a comment line inside it ends the table there, silently (the
  correction of its last line is held beyond it: why our comments follow the triplets); two lines out of
  order are reported ("joint N: compensation values must increase") and the second left out.

LinuxCNC is one per machine (its lock file /tmp/linuxcnc.lock, shared memory, processes found by name):
the test takes a lock of its own so that two runs of it wait for each other, refuses to start beside a
LinuxCNC it did not start, runs it in its own process group with a timeout and, should it not exit,
stops that group and unloads HAL (`halrun -U`); it checks that nothing of LinuxCNC runs afterwards.

Skips (exit code 77) only when LinuxCNC is not installed (`linuxcnc-uspace`; scripts/setup.sh installs it).

usage: linuxcnc_comp_test.py BUILD_DIR SOURCE_DIR
"""
import bisect
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib

SKIP = 77
LINUXCNC = "/usr/bin/linuxcnc"
LINUXCNC_TIMEOUT_S = 120
# The tables hold 1 nm (6 decimals). LinuxCNC updates a joint's correction only while the joint moves: at
# rest it holds that of the last servo period in motion, a fraction of a um before the target; on these
# tables' slopes (about 2 um/mm along the lead error) that is 0.3 nm.
TOLERANCE_MM = 1e-6
# Where the axes end up, about their mean: the map's agreement with the machine (compensate_cli_test:
# 0.25 um RMS) and the lead error's interpolation between 1 mm lines (up to 0.14 of its 1.5 um at a line).
LEFT_UM = 0.4
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "scripts"))
from linuxcnc_loop import fragment_sections, lingering_linuxcnc, machine_lock, read_comp  # noqa: E402
AXES = "XYZ"
NOBODY_UID = 65534


def table_correction_mm(rows, position_mm, moving_up):
    """What the table says LinuxCNC should add at a position: nominal - actual of the direction's column,
    linear between lines (positions inside the table only)."""
    noms = [r[0] for r in rows]
    i = bisect.bisect_right(noms, position_mm) - 1
    assert 0 <= i < len(rows) - 1, f"{position_mm} mm is outside the table {noms[0]}..{noms[-1]}"
    col = 1 if moving_up else 2
    c0, c1 = rows[i][0] - rows[i][col], rows[i + 1][0] - rows[i + 1][col]
    return c0 + (c1 - c0) * (position_mm - noms[i]) / (noms[i + 1] - noms[i])


HAL = """# The motion controller with every joint looped back: the drive is where it is commanded.
loadrt [KINS]KINEMATICS
loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS
addf motion-command-handler servo-thread
addf motion-controller servo-thread
net j0-pos joint.0.motor-pos-cmd => joint.0.motor-pos-fb
net j1-pos joint.1.motor-pos-cmd => joint.1.motor-pos-fb
net j2-pos joint.2.motor-pos-cmd => joint.2.motor-pos-fb
net estop-loop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in
net tool-prepare-loop iocontrol.0.tool-prepare => iocontrol.0.tool-prepared
net tool-change-loop iocontrol.0.tool-change => iocontrol.0.tool-changed
"""


def write_config(config_dir, comp_dir, plan, other_tables=None):
    """A headless LinuxCNC 2.9 configuration in config_dir: comp_dir's tables copied next to the INI and
    its linuxcnc.ini lines added to the [JOINT_n] sections, as docs/compensation.md tells a user.
    other_tables: {joint: table path} for joints the fragment leaves free."""
    os.makedirs(config_dir)
    fragment = fragment_sections(os.path.join(comp_dir, "linuxcnc.ini"))
    for joint, path in (other_tables or {}).items():
        assert f"JOINT_{joint}" not in fragment, joint
        shutil.copy(path, config_dir)
        name = os.path.basename(path)
        fragment[f"JOINT_{joint}"] = [f"COMP_FILE = {name}", "COMP_FILE_TYPE = 0", "BACKLASH = 0"]
    for lines in fragment.values():
        for line in lines:
            key, value = (s.strip() for s in line.split("=", 1))
            if key == "COMP_FILE" and not os.path.exists(os.path.join(config_dir, value)):
                shutil.copy(os.path.join(comp_dir, value), os.path.join(config_dir, value))
    with open(os.path.join(config_dir, "comp_check.hal"), "w") as f:
        f.write(HAL)
    open(os.path.join(config_dir, "sim.var"), "w").close()
    with open(os.path.join(config_dir, "tool.tbl"), "w") as f:
        f.write("T1 P1 D0 Z0 ;\n")
    with open(os.path.join(config_dir, "plan.json"), "w") as f:
        json.dump(plan, f)
    limit_mm = 1000
    ini = [
        "[EMC]", "VERSION = 1.1", "MACHINE = guideway-comp-check", "DEBUG = 0", "",
        "[DISPLAY]", f"DISPLAY = {os.path.join(HERE, 'linuxcnc_comp_display.py')}", "",
        "[GUIDEWAY_TEST]", f"PLAN = {os.path.join(config_dir, 'plan.json')}",
        f"RESULT = {os.path.join(config_dir, 'result.json')}", "",
        "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "",
        "[RS274NGC]", "PARAMETER_FILE = sim.var", "",
        "[EMCIO]", "EMCIO = io", "CYCLE_TIME = 0.100", "TOOL_TABLE = tool.tbl", "",
        "[EMCMOT]", "EMCMOT = motmod", "SERVO_PERIOD = 1000000", "COMM_TIMEOUT = 1.0", "",
        "[HAL]", "HALFILE = comp_check.hal", "",
        "[TRAJ]", "COORDINATES = XYZ", "LINEAR_UNITS = mm", "ANGULAR_UNITS = degree",
        "MAX_LINEAR_VELOCITY = 200", "DEFAULT_LINEAR_VELOCITY = 100", "",
        "[KINS]", "JOINTS = 3", "KINEMATICS = trivkins coordinates=XYZ", "",
    ]
    for j, axis in enumerate(AXES):
        ini += [f"[AXIS_{axis}]", f"MIN_LIMIT = {-limit_mm}", f"MAX_LIMIT = {limit_mm}", "MAX_VELOCITY = 200",
                "MAX_ACCELERATION = 4000", ""]
        ini += [f"[JOINT_{j}]", "TYPE = LINEAR", f"MIN_LIMIT = {-limit_mm}", f"MAX_LIMIT = {limit_mm}",
                "MAX_VELOCITY = 200", "MAX_ACCELERATION = 4000", "FERROR = 1", "MIN_FERROR = 1",
                "HOME = 0", "HOME_OFFSET = 0", "HOME_SEARCH_VEL = 0", "HOME_LATCH_VEL = 0",
                "HOME_SEQUENCE = 0"]
        ini += fragment.pop(f"JOINT_{j}", [])
        ini.append("")
    assert not fragment, f"linuxcnc.ini has sections this machine has no joint for: {sorted(fragment)}"
    path = os.path.join(config_dir, "comp_check.ini")
    with open(path, "w") as f:
        f.write("\n".join(ini))
    return path


def run_linuxcnc(ini_path, log_path, fifo_dir):
    """`linuxcnc INI` without a terminal or X, in its own process group; its output to log_path. Returns
    (exit code, output, seconds)."""
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env["HOME"] = os.path.dirname(log_path)  # where the linuxcnc script writes linuxcnc_print.txt, _debug.txt
    env["RTAPI_FIFO_PATH"] = os.path.join(fifo_dir, "rtapi_fifo")  # not in $HOME: the test's own
    if os.getuid() == 0:
        # rtapi_app: "Refusing to run as root without fallback UID specified"; it binds its socket as that user
        env["RTAPI_UID"] = str(NOBODY_UID)
        os.chown(fifo_dir, NOBODY_UID, -1)
    start = time.monotonic()
    with open(log_path, "w") as log:
        proc = subprocess.Popen([LINUXCNC, "-r", ini_path], stdin=subprocess.DEVNULL, stdout=log,
                                stderr=subprocess.STDOUT, env=env, start_new_session=True)
        try:
            code = proc.wait(timeout=LINUXCNC_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGTERM)  # the linuxcnc script's trap shuts LinuxCNC down
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
            subprocess.run(["halrun", "-U"], stdin=subprocess.DEVNULL, capture_output=True)
            code = None
    seconds = time.monotonic() - start
    with open(log_path) as f:
        output = f.read()
    return code, output, seconds


def make_tables(exe, machine, work, plane, center_mm):
    """A ccw + cw pair on the virtual machine and `guideway compensate dbb` on it, as a user makes them."""
    runs = []
    arc = ["--start-deg", "-20", "--arc-deg", "220"] if plane != "xy" else []  # a vertical plane: above the centre
    for direction in ("ccw", "cw"):
        out = os.path.join(work, f"{plane}-{direction}.csv")
        subprocess.run([exe, "simulate", "dbb", "--machine", machine, "--plane", plane, "--radius-mm", "100",
                        "--feed-mm-per-min", "250", "--sample-rate-hz", "8", "--direction", direction, "--center-mm",
                        *(str(c) for c in center_mm), *arc, "--out", out], check=True, stdout=subprocess.DEVNULL)
        runs.append(out)
    comp = os.path.join(work, f"comp-{plane}")
    subprocess.run([exe, "compensate", "dbb", *runs, "--out-dir", comp], check=True, stdout=subprocess.DEVNULL)
    return comp


def plan_moves(axis, joint, rows, positions=6):
    """Moves of one axis through positions between the table's lines (one exactly on a line, one in the
    first and one in the last interval), each reached once moving up and once moving down."""
    first, last = rows[0][0], rows[-1][0]
    step = rows[1][0] - rows[0][0]
    span = last - first
    at = [first + 0.37 * step, rows[len(rows) // 2][0], last - 0.41 * step]  # first interval, a line, last interval
    at += [first + span * k / (positions - 2) + 0.29 * step for k in range(1, positions - 2)]
    at = sorted(round(p, 6) for p in at)
    below, above = round(first + 0.1 * step, 6), round(last - 0.1 * step, 6)
    return [{"axis": axis, "joint": joint, "to_mm": p} for p in [below, *at, above, *reversed(at)]]


def compare(samples, tables):
    """Per sample the correction LinuxCNC applied against the table's; the direction is that of the move."""
    rows_out, last_mm = [], {}
    for s in samples:
        j = s["joint"]
        before = last_mm.get(j, 0.0)  # homed at 0
        last_mm[j] = s["to_mm"]
        if j not in tables:
            continue
        applied = s["motor-pos-cmd"] - s["pos-cmd"] - s["motor-offset"]
        up = s["to_mm"] > before
        expected = table_correction_mm(tables[j], s["pos-cmd"], up)
        rows_out.append({"axis": s["axis"], "to_mm": s["to_mm"], "up": up, "applied_mm": applied,
                         "table_mm": expected, "diff_mm": applied - expected,
                         "motor_mm": s["motor-pos-cmd"] - s["motor-offset"]})
    return rows_out


def write_machine(source, work):
    """config/machine-leadscrew.toml (X: scale, backlash, a 5 mm lead error; Y: scale, backlash) with a
    scale error and backlash on Z, so that every table's forward and reverse columns differ."""
    with open(os.path.join(source, "config", "machine-leadscrew.toml")) as f:
        text = f.read()
    z = "[axis.z]\nservo_lag_ms = 20.0\n"
    assert z in text, "config/machine-leadscrew.toml's [axis.z] changed: update this test"
    path = os.path.join(work, "machine.toml")
    with open(path, "w") as f:
        f.write(text.replace(z, z + "scale_ppm = 20\nbacklash_um = 5.0\nencoder_resolution_um = 0.1\n"))
    return path


def corrupted_copy(path, work, name, edit):
    """A copy of a table with its lines edited in place by edit(lines)."""
    with open(path) as f:
        lines = f.read().splitlines(keepends=True)
    edit(lines)
    out = os.path.join(work, name)
    with open(out, "w") as f:
        f.writelines(lines)
    return out


def run_config(name, work, comp_dir, plan, other_tables=None):
    """Writes the configuration, runs LinuxCNC on it; returns its result JSON and its output."""
    config_dir = os.path.join(work, name)
    ini = write_config(config_dir, comp_dir, plan, other_tables)
    fifo_dir = tempfile.mkdtemp(prefix="guideway-rtapi-")
    try:
        code, output, seconds = run_linuxcnc(ini, os.path.join(config_dir, "linuxcnc.log"), fifo_dir)
    finally:
        shutil.rmtree(fifo_dir, ignore_errors=True)
    left = lingering_linuxcnc()
    assert not left, f"{name}: LinuxCNC's processes still run after it exited: {left}\n{output}"
    assert code == 0, f"{name}: linuxcnc exited with {code} after {seconds:.0f} s:\n{output}"
    result_path = os.path.join(config_dir, "result.json")
    assert os.path.exists(result_path), f"{name}: the display program wrote no result:\n{output}"
    with open(result_path) as f:
        result = json.load(f)
    assert result["error"] is None, f"{name}: {result['error']}\n{output}"
    print(f"{name}: LinuxCNC ran {seconds:.1f} s, {len(result['samples'])} moves")
    return result, output


def tables_of(comp_dir):
    """{joint: triplets} of the tables the fragment names."""
    out = {}
    for section, lines in fragment_sections(os.path.join(comp_dir, "linuxcnc.ini")).items():
        joint = int(section.split("_")[1])
        for line in lines:
            key, value = (s.strip() for s in line.split("=", 1))
            if key == "COMP_FILE":
                out[joint] = read_comp(os.path.join(comp_dir, value))
    return out


LOADER_COMPLAINTS = ("compensation", "can't open", "COMP_FILE")
SWAPPED_REPORT = "joint 1: compensation values must increase"  # src/emc/motion/command.c, EMCMOT_SET_JOINT_COMP
BACKLASH_MIN_MM = 1e-3  # every table of the machine holds at least 4 um between its forward and reverse columns


def complaints(output, messages, expected=()):
    """What LinuxCNC said about the tables in its output and on its error channel, less what is expected."""
    said = [line.strip() for line in output.splitlines() + messages if any(c in line for c in LOADER_COMPLAINTS)]
    return [line for line in said if line not in expected]


def check_applied(name, comparison, axes):
    """Every table applied at every position as the table says, by the direction of the last move."""
    for r in comparison:
        print(f"  {r['axis']} {r['to_mm']:10.4f} mm {'up  ' if r['up'] else 'down'}"
              f"  LinuxCNC {r['applied_mm'] * 1e3:+9.4f} um"
              f"  table {r['table_mm'] * 1e3:+9.4f} um  diff {r['diff_mm'] * 1e6:+.3f} nm")
    assert sorted({r["axis"] for r in comparison}) == sorted(axes), (name, axes)
    bad = [r for r in comparison if abs(r["diff_mm"]) > TOLERANCE_MM]
    assert not bad, f"{name}: LinuxCNC's correction differs from the table's: {bad}"
    # The direction matters: at each position the correction moving up and moving down differ by the backlash.
    by_position = {}
    for r in comparison:
        by_position.setdefault((r["axis"], r["to_mm"]), {})[r["up"]] = r["applied_mm"]
    pairs = [v for v in by_position.values() if len(v) == 2]
    assert len(pairs) >= 6 * len(axes), f"{name}: {len(pairs)} positions reached in both directions"
    assert all(v[True] - v[False] > BACKLASH_MIN_MM for v in pairs), \
        f"{name}: forward/reverse not applied: {by_position}"
    worst = max(abs(r["diff_mm"]) for r in comparison)
    largest = max(abs(r["applied_mm"]) for r in comparison)
    print(f"{name}: {len(comparison)} moves ({len(pairs)} positions both ways) on {', '.join(axes)}: corrections up to "
          f"{largest * 1e3:.3f} um, max |LinuxCNC - table| {worst * 1e6:.3f} nm")


def machine_error_um(a, position_mm, up):
    """The virtual machine's own error of an axis at rest (docs/machine.md): actual - servo position; a is the
    machine file's [axis.N] table."""
    e = a.get("scale_ppm", 0.0) * 1e-3 * position_mm + (-0.5 if up else 0.5) * a.get("backlash_um", 0.0)
    if "cyclic_amplitude_um" in a:
        e += a["cyclic_amplitude_um"] * math.sin(2 * math.pi * position_mm / a["cyclic_period_mm"]
                                                 + math.radians(a["cyclic_phase_deg"]))
    return e


def check_axes_end_up_commanded(name, comparison, machine):
    """Our sign: with LinuxCNC's correction the machine's axis ends where the program said, about a constant
    (a DBB sees no offset), from either side: the drive at motor-pos-cmd, the carriage its error away."""
    with open(machine, "rb") as f:
        axes = tomllib.load(f)["axis"]
    by_axis = {}
    for r in comparison:
        err_um = machine_error_um(axes[r["axis"].lower()], r["motor_mm"], r["up"])
        by_axis.setdefault(r["axis"], []).append((r["applied_mm"] * 1e3 + err_um, err_um))
    for axis, values in by_axis.items():
        left = [v[0] for v in values]
        raw = [v[1] for v in values]
        spread = max(abs(v - sum(left) / len(left)) for v in left)
        raw_spread = max(abs(v - sum(raw) / len(raw)) for v in raw)
        print(f"{name}: {axis} where commanded within {spread:.3f} um (about their mean; "
              f"uncompensated {raw_spread:.3f} um)")
        assert spread < LEFT_UM, (name, axis, spread, values)


def check_comment_inside(samples, joint, full, loaded):
    """A table with a comment line inside: LinuxCNC took the lines above it and, past the last of them,
    holds that line's correction; the lines below the comment are ignored, and it says nothing."""
    flat = {True: loaded[-1][0] - loaded[-1][1], False: loaded[-1][0] - loaded[-1][2]}
    past = 0
    for r in compare(samples, {joint: full}):
        if r["to_mm"] < loaded[-1][0]:
            assert abs(r["diff_mm"]) <= TOLERANCE_MM, r
        else:
            past += 1
            assert abs(r["applied_mm"] - flat[r["up"]]) <= TOLERANCE_MM, (r, flat)
    assert past >= 4, past
    print(f"comment inside a table: the {len(loaded)} lines above it applied, the last one's correction held past "
          f"{loaded[-1][0]} mm at {past} positions, nothing reported")


def check_swapped(samples, joint, full, swapped):
    """A table with two lines out of order: LinuxCNC leaves out the line that does not increase, says so, and
    loads every other line (those after it too)."""
    kept = [swapped[0]]
    for row in swapped[1:]:
        if row[0] > kept[-1][0]:
            kept.append(row)
    missing = [row for row in full if row not in kept]
    assert len(missing) == 1, missing
    for r in compare(samples, {joint: kept}):
        assert abs(r["diff_mm"]) <= TOLERANCE_MM, r
    at_missing = [r for r in compare(samples, {joint: full}) if r["to_mm"] == missing[0][0]]
    assert len(at_missing) == 2 and all(abs(r["diff_mm"]) > 100 * TOLERANCE_MM for r in at_missing), at_missing
    print(f"two lines out of order: LinuxCNC reports '{SWAPPED_REPORT}', leaves out the line at {missing[0][0]} mm "
          f"(there {at_missing[0]['diff_mm'] * 1e3:+.3f} um from the whole table) and applies the other "
          f"{len(kept)} lines")


def main():
    build, source = sys.argv[1], sys.argv[2]
    if not os.path.exists(LINUXCNC):
        print("SKIP: LinuxCNC is not installed (Debian package linuxcnc-uspace; scripts/setup.sh installs it)")
        return SKIP
    exe = os.path.join(build, "cli", "guideway")
    with machine_lock():
        others = lingering_linuxcnc()
        assert not others, f"a LinuxCNC this test did not start runs on this machine (pids {others}): starting " \
                           "another would stop it"
        with tempfile.TemporaryDirectory(prefix="guideway-linuxcnc-") as work:
            check_planes(exe, source, work)
    return 0


def check_planes(exe, source, work):
    machine = write_machine(source, work)
    comp_xy = make_tables(exe, machine, work, "xy", (50, 20, 0))
    comp_xz = make_tables(exe, machine, work, "xz", (50, 20, -30))
    xy, xz = tables_of(comp_xy), tables_of(comp_xz)
    assert sorted(xy) == [0, 1] and sorted(xz) == [0, 2], (sorted(xy), sorted(xz))
    feed = 12000

    # XY's x.comp and y.comp; joint 2 gets y.comp with a comment line in the middle.
    half = len(xy[1]) // 2
    commented = corrupted_copy(os.path.join(comp_xy, "y.comp"), work, "comment-inside.comp",
                               lambda lines: lines.insert(half, "# a comment inside the table\n"))
    plan = {"feed_mm_per_min": feed,
            "moves": plan_moves("X", 0, xy[0]) + plan_moves("Y", 1, xy[1]) + plan_moves("Z", 2, xy[1])}
    result, output = run_config("xy", work, comp_xy, plan, {2: commented})
    assert not complaints(output, result["messages"]), complaints(output, result["messages"])
    applied = compare(result["samples"], xy)
    check_applied("xy", applied, ["X", "Y"])
    check_axes_end_up_commanded("xy", applied, machine)
    check_comment_inside(result["samples"], 2, xy[1], read_comp(commented))

    # XZ's x.comp and z.comp; joint 1 gets XY's x.comp (the lead error: not linear) with the centre line and
    # the next swapped: LinuxCNC reports the centre line, leaves it out and interpolates over it.
    centre = len(xy[0]) // 2
    swapped = corrupted_copy(
        os.path.join(comp_xy, "x.comp"), work, "swapped.comp",
        lambda lines: lines.__setitem__(slice(centre, centre + 2), [lines[centre + 1], lines[centre]]))
    plan = {"feed_mm_per_min": feed,
            "moves": plan_moves("X", 0, xz[0]) + plan_moves("Z", 2, xz[2]) + plan_moves("Y", 1, xy[0])}
    result, output = run_config("xz", work, comp_xz, plan, {1: swapped})
    assert SWAPPED_REPORT in result["messages"] and SWAPPED_REPORT in output, (result["messages"], output)
    assert not complaints(output, result["messages"], [SWAPPED_REPORT]), complaints(output, result["messages"])
    check_swapped(result["samples"], 1, xy[0], read_comp(swapped))
    applied = compare(result["samples"], xz)
    check_applied("xz", applied, ["X", "Z"])
    check_axes_end_up_commanded("xz", applied, machine)


if __name__ == "__main__":
    sys.exit(main())
