#!/usr/bin/python3
"""LinuxCNC in the loop, headless (docs/linuxcnc.md): the controller moves the virtual machine, Guideway
measures it, LinuxCNC loads the correction, and the test runs again.

  1. `guideway program dbb` writes the test's G-code (the standard ccw + cw circles with feed-in/feed-out
     arcs, the session pin raised over them);
  2. guidewayd starts with the DBB device on guideway-emulate dbb --follow: the virtual machine moves as
     LinuxCNC commands it, servo period by servo period, through guideway-linuxcnc-bridge;
  3. LinuxCNC (Debian's linuxcnc-uspace, the configuration in linuxcnc/sim/, as an unprivileged user)
     runs the program; guidewayd records the session and identifies it;
  4. `guideway compensate dbb --latest` writes the tables, `guideway linuxcnc offsets` the HAL file of the
     squareness and straightness (LinuxCNC's external offsets);
  5. LinuxCNC restarts with them and runs the same program; guidewayd measures again;
  6. `guideway report` shows both sessions' polar plots; the last line gives G before and after.

It also records each LinuxCNC run's bridge stream and checks, period by period, that what LinuxCNC applied
is what the files say (the tables' correction, the external offsets) and that no servo period was lost
(the bridge's, the emulator's and our own count). Exit 0 when the loop ran, 1 when it failed, 77 (skip)
when LinuxCNC cannot start here (the reason is printed).

usage: linuxcnc_loop.py [--bin-dir DIR] [--share-dir DIR] [--work DIR] [--machine FILE] [--radius-mm R]
                        [--feed-mm-per-min F] [--json FILE] [--keep]
"""
import argparse
import contextlib
import fcntl
import json
import math
import os
import pwd
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

SKIP = 77
LINUXCNC = "/usr/bin/linuxcnc"
LOOP_USER = "guideway-lcnc"
HERE = os.path.dirname(os.path.abspath(__file__))
START = time.monotonic()


def say(text):
    print(text, flush=True)


def elapsed():
    return f"[{time.monotonic() - START:5.0f} s]"


class Skip(Exception):
    """LinuxCNC cannot run here: the reason."""


class Failed(Exception):
    """The loop did not work: the reason."""


def find_tool(name, bin_dir, subdir):
    """A Guideway program: in the build tree (bin_dir/subdir/name), beside it (bin_dir/name) or on PATH."""
    for candidate in ([os.path.join(bin_dir, subdir, name), os.path.join(bin_dir, name)] if bin_dir else []):
        if os.access(candidate, os.X_OK):
            return os.path.abspath(candidate)
    # guidewayd is in /usr/sbin, which a user's PATH may lack
    found = shutil.which(name) or shutil.which(name, path="/usr/sbin:/usr/local/sbin")
    if not found:
        raise Failed(f"{name} not found (give --bin-dir BUILD_DIR, or install the guideway package)")
    return found


def lingering_linuxcnc():
    pids = []
    for name in ("milltask", "linuxcncsvr", "rtapi_app", "halsampler"):
        pids += subprocess.run(["pidof", name], capture_output=True, text=True).stdout.split()
    return pids


@contextlib.contextmanager
def machine_lock():
    """One LinuxCNC per machine: shared with tests/linuxcnc/linuxcnc_comp_test.py."""
    path = os.path.join(tempfile.gettempdir(), "guideway-linuxcnc-test.lock")
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        fd = os.open(path, os.O_RDONLY | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def loop_user():
    """The user LinuxCNC runs as: ourselves, or (as root, which LinuxCNC's rtapi refuses) a system user of
    our own, created when missing. None with the reason when there is none."""
    if os.getuid() != 0:
        return pwd.getpwuid(os.getuid()).pw_name, None
    try:
        pwd.getpwnam(LOOP_USER)
    except KeyError:
        res = subprocess.run(["useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", LOOP_USER],
                             capture_output=True, text=True)
        if res.returncode != 0:
            return None, f"cannot create the user {LOOP_USER} LinuxCNC runs as: {res.stderr.strip()}"
    return LOOP_USER, None


class Process:
    """A child in its own process group whose output goes, line by line, to a log file and (prefixed) to
    our output when `echo` says so; stopped by its pid at the end."""

    def __init__(self, name, argv, log_path, echo=None, env=None, stdin=subprocess.DEVNULL):
        self.name = name
        self.log = open(log_path, "w")
        self.lines = []
        self.proc = subprocess.Popen(argv, stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     env=env, start_new_session=True, bufsize=1)
        self.echo = echo
        self.thread = threading.Thread(target=self._pump, daemon=True)
        self.thread.start()

    def _pump(self):
        for line in self.proc.stdout:
            self.log.write(line)
            self.log.flush()
            self.lines.append(line.rstrip("\n"))
            if self.echo:
                shown = self.echo(line.rstrip("\n"))
                if shown:
                    say(f"{elapsed()} {shown}")

    def running(self):
        return self.proc.poll() is None

    def wait(self, timeout):
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None
        self.thread.join(timeout=5)
        return code

    def stop(self, sig=signal.SIGTERM, timeout=15):
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, sig)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.thread.join(timeout=5)
        self.log.close()


class StreamRecorder:
    """A client of the bridge: keeps every line of one LinuxCNC run's stream (to check it afterwards)."""

    def __init__(self, path, out_path):
        self.path, self.out_path = path, out_path
        self.stop_flag = False
        self.connected = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        with open(self.out_path, "w") as out:
            while not self.stop_flag:
                s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                try:
                    s.connect(self.path)
                except OSError:
                    s.close()
                    time.sleep(0.05)
                    continue
                self.connected = True
                s.settimeout(0.2)
                while not self.stop_flag:
                    try:
                        data = s.recv(1 << 16)
                    except socket.timeout:
                        continue
                    if not data:
                        break
                    out.write(data.decode())
                s.close()
                return

    def stop(self):
        self.stop_flag = True
        self.thread.join(timeout=5)


def read_stream(path):
    """The recorded stream: header, periods (seq, values), lost lines."""
    header, periods, lost = {}, [], []
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("#"):
                if "=" in line:
                    k, v = (x.strip() for x in line[1:].split("=", 1))
                    header[k] = v
            elif line.startswith("!"):
                lost.append(line)
            elif line.strip():
                parts = line.split()
                periods.append((int(parts[0]), [float(x) for x in parts[1:]]))
    return header, periods, lost


def cli(tools, socket_path, *args, timeout=60, check=True):
    res = subprocess.run([tools["guideway"], "--socket", socket_path, *args], capture_output=True, text=True,
                         timeout=timeout)
    if check and res.returncode != 0:
        raise Failed(f"guideway {' '.join(args)}: {res.stderr.strip() or res.stdout.strip()}")
    return res


# The virtual machine's slack behind LinuxCNC: a loaded PC stalls LinuxCNC's uspace servo thread now and then,
# for up to 3 s; at 1 s of slack the playback ran dry mid-circle (an underrun stops the machine, cuts the run).
FOLLOW_DELAY_MS = 4000


def daemon_config(work, args):
    """guidewayd's configuration: the DBB bus of the emulator the loop starts (no emulators of its own)."""
    bar = f"""  [[device.encoder]]
  channel = "bar_length"
  node_id = 1
  resolution_nm = 100
  offset_mm = {args.radius_mm}
"""
    axes = "".join(f"""  [[device.encoder]]
  channel = "{a}"
  node_id = {n}
  resolution_nm = 100
""" for n, a in ((2, "x"), (3, "y"), (4, "z")))
    # The virtual machine's fifth node: the servo period it plays, a thousandth of a period per count, so that
    # the session pairs each reading with LinuxCNC's command of the same period (docs/linuxcnc.md).
    period = """  [[device.encoder]]
  channel = "controller_period"
  node_id = 5
  resolution_nm = 1000000
"""
    text = f"""# guidewayd of scripts/linuxcnc_loop.py: the ball bar and the X/Y/Z encoders of the virtual machine that
# LinuxCNC moves (guideway-emulate dbb --follow, started by the loop).
[daemon]
socket = "{work}/guideway.sock"
state_dir = "{work}/state"
log_level = "info"

[[device]]
name = "dbb"
driver = "dbb-can"
bus = "unix:{work}/can-bus.sock"
sync = "produce"
sync_rate_hz = 250.0
configure_nodes = true
heartbeat_ms = 100
{bar}{axes}{period}
# LinuxCNC itself: its commanded positions and the program's session pin, through guideway-linuxcnc-bridge.
[[device]]
name = "linuxcnc"
driver = "linuxcnc-hal"
socket = "{work}/run/linuxcnc.sock"

# The test program raises motion.digital-out-00 over its circles (M62 P0 ... M65 P0): the session runs
# while it is up.
[[session_trigger]]
device = "linuxcnc"
channel = "session"
kind = "dbb"
session_device = "dbb"
options = {{ test = "standard", radius_mm = {args.radius_mm}, feed_mm_per_min = {args.feed_mm_per_min} }}
# the bar's last readings come the virtual machine's playback delay after LinuxCNC's pin falls, longer when
# LinuxCNC stalled for long (the delay grows to 1.5 times the longest stall); a session that has traced its
# runs ends at once
end_after_s = {3 * FOLLOW_DELAY_MS / 1000 + 3:g}
"""
    path = os.path.join(work, "guidewayd.toml")
    with open(path, "w") as f:
        f.write(text)
    return path


def linuxcnc_config(share, work, name, tools, program, socket_path, comp_dir=None):
    """A copy of linuxcnc/sim/ in work/name, filled in; with comp_dir, the [JOINT_n] lines of its linuxcnc.ini
    added to the joints' sections (as docs/compensation.md tells a user) and its HAL file of external offsets
    added to [HAL] with the [AXIS_L] lines it asks for."""
    cfg = os.path.join(work, name)
    os.makedirs(cfg)
    for f in ("sim/guideway-sim.hal", "guideway-bridge.hal", "guideway_headless.py"):
        shutil.copy(os.path.join(share, f), cfg)
    open(os.path.join(cfg, "sim.var"), "w").close()
    with open(os.path.join(cfg, "tool.tbl"), "w") as f:
        f.write("T1 P1 D0 Z0 ;\n")
    joints = {0: [], 1: [], 2: []}
    axes = {"X": [], "Y": [], "Z": []}
    halfiles = []
    if comp_dir:
        joints, axes, halfiles = load_compensation(comp_dir, cfg, joints, axes)
    with open(os.path.join(share, "sim", "guideway-sim.ini")) as f:
        ini = f.read()
    ini = (ini.replace("@DISPLAY@", os.path.join(cfg, "guideway_headless.py"))
           .replace("@PROGRAM@", program).replace("@RESULT@", os.path.join(cfg, "result.json"))
           .replace("@BRIDGE@", tools["guideway-linuxcnc-bridge"]).replace("@SOCKET@", socket_path)
           .replace("@HALFILES@", "\n".join(f"HALFILE = {h}" for h in halfiles)))
    limit = ["MIN_LIMIT = -1000", "MAX_LIMIT = 1000", "MAX_VELOCITY = 200", "MAX_ACCELERATION = 2000"]
    for j, axis in enumerate("XYZ"):
        ini += "\n".join([f"\n[AXIS_{axis}]", *limit, *axes[axis]]) + "\n"
        ini += "\n".join([f"\n[JOINT_{j}]", "TYPE = LINEAR", *limit, "FERROR = 1", "MIN_FERROR = 1", "HOME = 0",
                          "HOME_OFFSET = 0", "HOME_SEARCH_VEL = 0", "HOME_LATCH_VEL = 0", "HOME_SEQUENCE = 0",
                          *joints[j]]) + "\n"
    path = os.path.join(cfg, "guideway-sim.ini")
    with open(path, "w") as f:
        f.write(ini)
    return cfg, path


def fragment_sections(path):
    """The `key = value` lines of each section of an INI fragment (comments left out)."""
    sections, current = {}, None
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s[0] in "#;":
                continue
            if s.startswith("[") and s.endswith("]"):
                current = sections.setdefault(s[1:-1], [])
            elif current is not None and "=" in s:
                current.append(s)
    return sections


def load_compensation(comp_dir, cfg, joints, axes):
    """What `guideway compensate` and `guideway linuxcnc offsets` wrote into comp_dir, placed as a user does."""
    halfiles = []
    fragments = [f for f in ("linuxcnc.ini", "linuxcnc-offsets.ini") if os.path.exists(os.path.join(comp_dir, f))]
    for fragment in fragments:
        for section, lines in fragment_sections(os.path.join(comp_dir, fragment)).items():
            if section.startswith("JOINT_"):
                joints[int(section.split("_")[1])] += lines
            elif section.startswith("AXIS_"):
                axes[section.split("_")[1]] += lines
            elif section == "HAL":
                halfiles += [v.split("=", 1)[1].strip() for v in lines if v.startswith("HALFILE")]
    for f in os.listdir(comp_dir):
        if f.endswith(".comp") or f.endswith(".hal"):
            shutil.copy(os.path.join(comp_dir, f), cfg)
    return joints, axes, halfiles


def headless_line(line):
    """What of LinuxCNC's output the loop shows: the headless display's progress and the bridge's words."""
    for prefix in ("guideway-headless: ", "guideway-linuxcnc-bridge: "):
        if line.startswith(prefix):
            return "LinuxCNC " + line
    return None


def run_linuxcnc(ini, cfg, user, timeout_s):
    """`linuxcnc INI` headless as `user`, its progress shown as it comes; the result of the display program."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["HOME"] = cfg  # linuxcnc writes its print and debug files there
    argv = [LINUXCNC, "-r", ini]
    if os.getuid() == 0:
        argv = ["runuser", "-u", user, "--", "env", f"HOME={cfg}", "PATH=" + env.get("PATH", "/usr/bin:/bin"),
                LINUXCNC, "-r", ini]
    proc = Process("linuxcnc", argv, os.path.join(cfg, "linuxcnc.log"), echo=headless_line, env=env)
    code = proc.wait(timeout_s)
    if code is None:
        proc.stop()
        subprocess.run(["halrun", "-U"], capture_output=True)
        raise Failed(f"LinuxCNC did not end within {timeout_s:.0f} s (log: {cfg}/linuxcnc.log)")
    proc.stop()
    result_path = os.path.join(cfg, "result.json")
    if code != 0 or not os.path.exists(result_path):
        tail = "\n".join(proc.lines[-25:])
        raise Failed(f"LinuxCNC exited with {code} and no result (log {cfg}/linuxcnc.log):\n{tail}")
    with open(result_path) as f:
        result = json.load(f)
    if result["error"]:
        raise Failed(f"LinuxCNC's run: {result['error']} (messages: {result['messages']})")
    result["log"] = proc.lines
    return result


class Daemon:
    """guidewayd with the follower emulator in front of it."""

    def __init__(self, tools, work, args, bridge_socket):
        self.tools, self.work = tools, work
        self.socket = os.path.join(work, "guideway.sock")
        emulate = [tools["guideway-emulate"], "dbb", "--bus", f"unix:{work}/can-bus.sock", "--nodes", "1", "2", "3",
                   "4", "5", "--follow", bridge_socket, "--plane", "xy", "--radius-mm", str(args.radius_mm),
                   "--center-mm", *(str(c) for c in args.center_mm),
                   "--follow-delay-ms", str(FOLLOW_DELAY_MS)]
        if args.machine:
            emulate += ["--machine", args.machine]
        self.emulator = Process("emulator", emulate, os.path.join(work, "emulator.log"),
                                echo=lambda l: "emulator " + l if l.startswith("follow:") else None,
                                stdin=subprocess.PIPE)
        if not wait_until(lambda: os.path.exists(f"{work}/can-bus.sock"), 10):
            raise Failed("guideway-emulate did not start:\n" + "\n".join(self.emulator.lines))
        config = daemon_config(work, args)
        self.daemon = Process("guidewayd", [tools["guidewayd"], "--config", config],
                              os.path.join(work, "guidewayd.log"))
        if not wait_until(lambda: cli(tools, self.socket, "version", check=False).returncode == 0, 20):
            raise Failed("guidewayd did not start:\n" + "\n".join(self.daemon.lines[-20:]))
        streaming = lambda: '"state":"streaming"' in cli(tools, self.socket, "status", "--json", check=False).stdout
        if not wait_until(streaming, 30):
            raise Failed("the DBB device does not stream:\n" + cli(tools, self.socket, "status", check=False).stdout)
        say(f"{elapsed()} guidewayd streams the virtual machine's ball bar and encoders (socket {self.socket})")

    def follower_status(self):
        """The emulator's own count of the periods it followed ("follow" on its control channel)."""
        before = len(self.emulator.lines)
        self.emulator.proc.stdin.write("follow\n")
        self.emulator.proc.stdin.flush()
        wait_until(lambda: any(l.startswith("ok follow: ") for l in self.emulator.lines[before:]), 5)
        for line in self.emulator.lines[before:]:
            if line.startswith("ok follow: "):
                return line[len("ok follow: "):]
        return "(no answer)"

    def stop(self):
        self.daemon.stop()
        if self.emulator.running():
            with contextlib.suppress(OSError):
                self.emulator.proc.stdin.write("quit\n")
                self.emulator.proc.stdin.flush()
        self.emulator.stop()


def wait_until(predicate, timeout_s, poll_s=0.1):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(poll_s)
    return predicate()


def session_line(line):
    return "guidewayd " + line.strip() if line.strip() else None


def latest_session(tools, socket_path):
    res = cli(tools, socket_path, "params", "dbb", "--json", check=False)
    return json.loads(res.stdout) if res.returncode == 0 else {}


def event_line(line):
    """guidewayd's EVENTs the loop shows: the sessions the controller's pin begins and ends, failures."""
    try:
        e = json.loads(line)
    except ValueError:
        return None
    if e.get("event", "").startswith("session") or e.get("event") in ("periods_lost", "recording_failed"):
        return f"guidewayd EVENT {e.get('event')}: {e.get('reason', '')}"
    return None


def measure(tag, daemon, work, args, user, share, comp_dir=None):
    """One LinuxCNC run of the test program, the session begun and ended by the program's pin: its PARAMS,
    the run's stream and LinuxCNC's result."""
    tools = daemon.tools
    bridge_socket = os.path.join(work, "run", "linuxcnc.sock")
    cfg, ini = linuxcnc_config(share, work, f"linuxcnc-{tag}", tools, args.program, bridge_socket, comp_dir)
    if os.getuid() == 0:
        shutil.chown(cfg, user)
    before = latest_session(tools, daemon.socket).get("session")
    events = Process(f"events-{tag}", [tools["guideway"], "--socket", daemon.socket, "watch",
                                       "--class", "EVENT", "--json"], os.path.join(work, f"events-{tag}.log"),
                     echo=event_line)
    stream_path = os.path.join(work, f"stream-{tag}.txt")
    recorder = StreamRecorder(bridge_socket, stream_path)
    say(f"{elapsed()} LinuxCNC starts ({'with the correction' if comp_dir else 'as it is'}): {ini}")
    try:
        result = run_linuxcnc(ini, cfg, user, args.timeout_s)
    finally:
        recorder.stop()
    say(f"{elapsed()} LinuxCNC ran the program in {result['seconds']:.1f} s and shut down; waiting for the "
        "session's identification")
    params = wait_for_session(tools, daemon.socket, before, args.timeout_s)
    events.stop()
    say(f"{elapsed()} the {tag} session {params.get('session')}, run by run: " + ", ".join(
        f"{r.get('direction')} G {r.get('circular_deviation_um', float('nan')):.2f} um" for r in params.get("runs", [])))
    explain_session(tools, daemon.socket, args.machine, tag, params.get("session", ""))
    return params, stream_path, result, cfg


def wait_for_session(tools, socket_path, before, timeout_s):
    """The PARAMS of the DBB session after `before`, with the session's progress every 10 s. The virtual
    machine plays LinuxCNC's periods a little late: a session still running 15 s after the program ended has
    seen all it will and is ended (it identifies what it traced)."""
    start, last, stopped = time.monotonic(), 0.0, False
    while time.monotonic() - start < timeout_s:
        p = latest_session(tools, socket_path)
        if p.get("session") and p.get("session") != before:
            return p
        status = json.loads(cli(tools, socket_path, "status", "--json", check=False).stdout or "{}")
        running = [x for x in status.get("sessions", []) if x.get("state") == "running"]
        failed = [x for x in status.get("sessions", []) if x.get("state") == "failed" and x.get("session") != before]
        if failed:
            raise Failed(f"session {failed[-1].get('session')} failed: {failed[-1].get('progress')}")
        if time.monotonic() - last > 10:
            last = time.monotonic()
            say(f"{elapsed()} guidewayd " + ("; ".join(f"session {x.get('session')}: {x.get('progress', '')}"
                                                     for x in running) or "identifying"))
        if running and not stopped and time.monotonic() - start > 15:
            stopped = True
            res = cli(tools, socket_path, "stop", check=False)
            say(f"{elapsed()} the program has ended: guideway stop ({res.stdout.strip() or res.stderr.strip()})")
        if not running and not stopped and time.monotonic() - start > 30:
            raise Failed("no session began: the program's pin (motion.digital-out-00) never reached guidewayd")
        time.sleep(0.5)
    raise Failed(f"no PARAMS within {timeout_s:.0f} s")


def explain_session(tools, socket_path, machine, tag, session):
    """EXPLAIN of the session just measured, as guidewayd published it, beside what the machine file holds."""
    def published():
        res = cli(tools, socket_path, "explain", "--latest", "--kind", "dbb", "--json", check=False)
        return res.returncode == 0 and json.loads(res.stdout).get("session") == session

    if not wait_until(published, 60, 0.5):
        say(f"{elapsed()} no EXPLAIN of the {tag} session")
        return
    res = cli(tools, socket_path, "explain", "--latest", "--kind", "dbb", *(["--machine", machine] if machine else []),
              check=False)
    say(f"{elapsed()} == guideway explain --latest ({tag}: what the model left out of LinuxCNC's runs)")
    say(res.stdout.rstrip() or res.stderr.rstrip())


def largest_g_um(params):
    """The circular deviation G of a session: the largest of its runs' (ISO 230-4), um."""
    runs = [r.get("circular_deviation_um") for r in params.get("runs", [])]
    runs = [float(g) for g in runs if isinstance(g, (int, float))]
    if not runs:
        raise Failed(f"the session's PARAMS have no runs with a circular deviation: {sorted(params)}")
    return max(runs)


def derived_runs(params):
    return [f for f in params.get("derived", []) if ".run" in os.path.basename(f) and f.endswith(".csv")]


def tagged_copies(runs, out_dir, tag):
    """The session's run files with `# compensation = TAG` added, so that `guideway report` pairs them."""
    os.makedirs(out_dir, exist_ok=True)
    out = []
    for path in runs:
        with open(path) as f:
            text = f.read()
        dest = os.path.join(out_dir, os.path.basename(path))
        with open(dest, "w") as f:
            f.write(f"# compensation = {tag}\n" + text)
        out.append(dest)
    return out


def check_stream(tag, stream_path, result, checks):
    """No servo period lost: the recorded stream's sample numbers without a gap or a `! lost` line, and the
    bridge's own count at LinuxCNC's shutdown without a lost period."""
    header, periods, lost = read_stream(stream_path)
    seqs = [p[0] for p in periods]
    gaps = sum(1 for a, b in zip(seqs, seqs[1:]) if b - a != 1)
    bridge = [l for l in result["log"] if "guideway-linuxcnc-bridge:" in l and " periods, " in l]
    say(f"{elapsed()} {tag}: the bridge's stream held {len(periods)} servo periods ({len(periods) / 1000:.1f} s), "
        f"{gaps} gaps in their numbers, {len(lost)} lost-period notices; the bridge said: "
        f"{bridge[-1].split(': ', 1)[1] if bridge else '(nothing)'}")
    checks.append((f"{tag}: stream without gaps", gaps == 0 and not lost))
    checks.append((f"{tag}: bridge lost nothing", bool(bridge) and " 0 lost to halsampler overruns, 0 dropped" in bridge[-1]))
    return header, periods


def read_run(path):
    """A run file: its metadata and its columns (name -> values)."""
    meta, names, cols = {}, None, {}
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                key, _, value = line[1:].partition("=")
                meta[key.strip()] = value.strip()
            elif names is None:
                names = line.strip().split(",")
                cols = {n: [] for n in names}
            elif line.strip():
                for n, v in zip(names, line.strip().split(",")):
                    cols[n].append(float(v))
    return meta, cols


CMD_TOLERANCE_MM = 1e-6  # the stream's %f: 1 nm


def check_commanded(tag, params, header, periods, checks):
    """The runs carry LinuxCNC's commanded position beside the bar's reading (`<a>_cmd_mm`, `<b>_cmd_mm`,
    `controller_period`, and the metadata `controller`, `controller_match`, `controller_lag_periods`,
    `controller_mismatch_um`: how far the encoders stayed from the command the lag earlier), paired by servo
    period: each row's command is the bridge's stream's of the row's period less the lag, to the nanometre."""
    cols_of = {c: i for i, c in enumerate(header.get("columns", "").split(","))}
    by_seq = {seq: values for seq, values in periods}
    carried = []
    for path in derived_runs(params):
        meta, cols = read_run(path)
        plane = meta.get("plane", "xy")
        wanted = [f"{plane[0]}_cmd_mm", f"{plane[1]}_cmd_mm"]
        ok = all(c in cols for c in wanted + ["controller_period"]) and meta.get("controller_match") == "servo period"
        worst, n = 0.0, 0
        if ok:
            lag = float(meta["controller_lag_periods"])
            for i, p in enumerate(cols["controller_period"]):
                q = p - lag
                j = math.floor(q)
                lo, hi = by_seq.get(j), by_seq.get(j + 1)
                if lo is None or hi is None:
                    continue
                w = q - j
                for c in wanted:
                    k = cols_of[c]
                    worst = max(worst, abs(cols[c][i] - (lo[k] + w * (hi[k] - lo[k]))))
                n += 1
            ok = n > 0.99 * len(cols["controller_period"]) and worst <= CMD_TOLERANCE_MM
        carried.append(ok)
        say(f"{elapsed()} {tag}: {os.path.basename(path)} " + (
            f"carries {', '.join(wanted)} from {meta.get('controller')}, paired by servo period: {n} rows, each the "
            f"stream's command {meta.get('controller_lag_periods')} periods before the row's within "
            f"{worst * 1e6:.2f} nm; the encoders followed it {meta.get('controller_lag_ms')} ms later, "
            f"{meta.get('controller_mismatch_um')} um from it on average"
            if ok else f"lacks the controller's commanded position paired by servo period (columns "
                       f"{','.join(cols)}, match {meta.get('controller_match')}, lag "
                       f"{meta.get('controller_lag_periods')} periods, {n} rows checked, worst {worst * 1e6:.1f} nm)"))
    checks.append((f"{tag}: runs carry LinuxCNC's commanded position of the reading's servo period",
                   bool(carried) and all(carried)))


FEED_MOTION = (2, 3)  # motion.motion-type: feed, arc (1 is a rapid)
TABLE_TOLERANCE_MM = 3e-6  # halsampler prints 6 decimals: three rounded numbers per correction
OFFSET_TOLERANCE_MM = 5e-6  # the offsets follow their input one servo period late (a few nm at 50 mm/s)


def read_comp(path):
    """Triplets as LinuxCNC reads them: from the top until the first line that is not three numbers."""
    rows = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            try:
                if len(parts) != 3:
                    break
                rows.append(tuple(float(p) for p in parts))
            except ValueError:
                break
    return rows


def interpolate(xs, ys, x):
    """Linear between points, end values beyond: a COMP_FILE's and lincurve's rule."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    lo, hi = 0, len(xs) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    return ys[lo] + (ys[hi] - ys[lo]) * (x - xs[lo]) / (xs[hi] - xs[lo])


MAX_SWITCH_PERIODS = 100  # LinuxCNC's switch between a table's columns after the commanded reversal


def check_tables(header, periods, comp_dir, checks, figures):
    """Period by period of the feed moves, what LinuxCNC added to each joint (motor-pos-cmd - pos-cmd -
    motor-offset) against the table's correction there for the direction of motion (nominal - actual,
    linear between lines), away from the reversals: 20 periods before each (the command slows to it,
    halsampler's 1 nm hides the sign) and after it until LinuxCNC has switched to the new direction's column,
    which it does late on some joints (measured: the periods from the commanded reversal to the first period
    within the tolerance of the new column; at most MAX_SWITCH_PERIODS, said per axis)."""
    col = {c: i for i, c in enumerate(header["columns"].split(","))}
    for axis in "xyz":
        path = os.path.join(comp_dir, f"{axis}.comp")
        if not os.path.exists(path):
            continue
        rows = read_comp(path)
        noms = [r[0] for r in rows]
        fwd, rev = [r[0] - r[1] for r in rows], [r[0] - r[2] for r in rows]
        cmds = [v[col[f"{axis}_cmd_mm"]] for _, v in periods]
        direction = [0] + [1 if b > a else -1 if b < a else 0 for a, b in zip(cmds, cmds[1:])]

        def error(k, d):
            v = periods[k][1]
            applied = v[col[f"{axis}_motor_mm"]] - cmds[k] - v[col[f"{axis}_motor_offset_mm"]]
            return abs(applied - interpolate(noms, fwd if d > 0 else rev, cmds[k]))

        near = [False] * len(cmds)
        switches = []  # periods from each commanded reversal of the feed moves to LinuxCNC's switch
        late = []  # (period, new direction, switch) of the switches later than 5 periods
        last = 0
        for k, d in enumerate(direction):
            if d and last and d != last:
                switch = next((i - k for i in range(k, min(len(cmds), k + MAX_SWITCH_PERIODS + 1))
                               if error(i, d) <= TABLE_TOLERANCE_MM), None)
                if periods[k][1][col["motion_type"]] in FEED_MOTION:
                    switches.append(switch)
                    if switch is None or switch > 5:
                        late.append((k, d, switch))
                for i in range(max(0, k - 20), min(len(cmds), k + max(20, (switch or MAX_SWITCH_PERIODS) + 1))):
                    near[i] = True
            last = d or last
        worst, n = 0.0, 0
        for k, (_, v) in enumerate(periods):
            if v[col["motion_type"]] not in FEED_MOTION or near[k] or not direction[k]:
                continue
            worst, n = max(worst, error(k, direction[k])), n + 1
        on_time = [x for x in switches if x is not None]
        say(f"{elapsed()} {axis}.comp as LinuxCNC applied it: {n} servo periods of the feed moves, within "
            f"{worst * 1e6:.1f} nm of the file's correction (its {len(rows)} lines); at {len(switches)} reversals "
            f"LinuxCNC switched to the new direction's column " +
            (f"{min(on_time)} to {max(on_time)} servo periods after the commanded reversal" if on_time else "never") +
            (f", {len(switches) - len(on_time)} times not within {MAX_SWITCH_PERIODS}"
             if len(on_time) < len(switches) else ""))
        if late:
            # Why LinuxCNC switched late is not known (docs/linuxcnc.md): the first late switch period by period,
            # what it applied against the old and the new column, the joint's commanded step and its offset.
            k, d, switch = late[0]
            old_col, new_col = (rev, fwd) if d > 0 else (fwd, rev)
            say(f"{elapsed()} {axis}.comp: the first late switch ({switch} periods; {len(late)} late of "
                f"{len(switches)}), from period {periods[k][0]} (applied, old column, new column, commanded step, "
                f"external offset; nm):")
            for i in range(max(0, k - 2), min(len(cmds), k + (switch or MAX_SWITCH_PERIODS) + 3),
                           max(1, (switch or MAX_SWITCH_PERIODS) // 10)):
                v = periods[i][1]
                applied = v[col[f"{axis}_motor_mm"]] - cmds[i] - v[col[f"{axis}_motor_offset_mm"]]
                step = cmds[i] - cmds[i - 1] if i else 0.0
                say(f"    {i - k:+4d}: {applied * 1e6:9.1f} {interpolate(noms, old_col, cmds[i]) * 1e6:9.1f} "
                    f"{interpolate(noms, new_col, cmds[i]) * 1e6:9.1f} {step * 1e6:9.1f} "
                    f"{v[col[f'{axis}_eoffset_mm']] * 1e6:9.1f}")
        figures[f"{axis}_switch_periods"] = [min(on_time), max(on_time)] if on_time else None
        checks.append((f"{axis}.comp applied as written", n > 1000 and worst <= TABLE_TOLERANCE_MM))
        checks.append((f"{axis}.comp: LinuxCNC switches its columns within {MAX_SWITCH_PERIODS} periods",
                       bool(switches) and len(on_time) == len(switches)))


def read_offsets_hal(path):
    """The lincurves of guideway-offsets.hal: corrected axis -> (moving axis, positions, counts)."""
    points, inputs, outputs = {}, {}, {}
    with open(path) as f:
        for line in f:
            p = line.split()
            if len(p) == 3 and p[0] == "setp" and p[1].startswith("lincurve."):
                _, k, field = p[1].split(".")
                points.setdefault(int(k), {}).setdefault(field[:5], []).append(float(p[2]))
            elif len(p) == 5 and p[0] == "net" and p[4].startswith("lincurve.") and p[4].endswith(".in"):
                inputs[int(p[4].split(".")[1])] = p[2].split(".")[1]
            elif len(p) >= 3 and p[0] == "net" and p[2].startswith("lincurve.") and p[2].endswith(".out"):
                outputs[int(p[2].split(".")[1])] = p[1].split("-")[1]
    return {k: (outputs[k], inputs[k], v["x-val"], v["y-val"]) for k, v in points.items()}


def check_offsets(header, periods, comp_dir, checks):
    """Period by period of the feed moves, each axis' external offset (axis.L.eoffset) against the sum of
    its lookups in guideway-offsets.hal at the moving axes' commanded positions."""
    path = os.path.join(comp_dir, "guideway-offsets.hal")
    if not os.path.exists(path):
        return
    col = {c: i for i, c in enumerate(header["columns"].split(","))}
    curves = read_offsets_hal(path)
    for axis in sorted({c[0] for c in curves.values()}):
        worst, n, largest = 0.0, 0, 0.0
        for _, v in periods:
            if v[col["motion_type"]] not in FEED_MOTION:
                continue
            want = sum(interpolate(xs, ys, v[col[f"{moving}_cmd_mm"]]) * 1e-6
                       for corrected, moving, xs, ys in curves.values() if corrected == axis)
            got = v[col[f"{axis}_eoffset_mm"]]
            worst, n, largest = max(worst, abs(got - want)), n + 1, max(largest, abs(got))
        say(f"{elapsed()} {axis}'s external offset as LinuxCNC applied it: {n} servo periods of the feed moves, "
            f"up to {largest * 1e3:.3f} um, within {worst * 1e6:.1f} nm of guideway-offsets.hal's lookups")
        checks.append((f"{axis}'s external offset applied as written", n > 1000 and worst <= OFFSET_TOLERANCE_MM))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin-dir", help="the build tree (default: the programs on PATH)")
    ap.add_argument("--share-dir", default=os.path.join(os.path.dirname(HERE), "linuxcnc"),
                    help="the LinuxCNC files (linuxcnc/ of the source, /usr/share/guideway/linuxcnc installed)")
    ap.add_argument("--work", help="working directory (default: a new one under /tmp, removed unless --keep)")
    ap.add_argument("--machine", help="the virtual machine tool file (default: config/machine-example.toml, the "
                    "emulator's own)")
    ap.add_argument("--radius-mm", type=float, default=100.0)
    ap.add_argument("--feed-mm-per-min", type=float, default=1000.0)
    ap.add_argument("--center-mm", type=float, nargs=3, default=[0.0, 0.0, 0.0])
    ap.add_argument("--timeout-s", type=float, default=600.0, help="for each LinuxCNC run and each session")
    ap.add_argument("--json", help="write the loop's figures here")
    ap.add_argument("--keep", action="store_true", help="keep the working directory")
    args = ap.parse_args()
    try:
        return loop(args)
    except Skip as e:
        say(f"SKIP: {e}")
        return SKIP
    except Failed as e:
        say(f"FAILED: {e}")
        return 1


def loop(args):
    if not args.machine:
        for candidate in (os.path.join(os.path.dirname(HERE), "config", "machine-example.toml"),
                          os.path.join(os.path.dirname(os.path.abspath(args.share_dir)), "machine-example.toml")):
            if os.path.exists(candidate):
                args.machine = candidate
                break
    if not os.path.exists(LINUXCNC):
        raise Skip("LinuxCNC is not installed (Debian package linuxcnc-uspace; scripts/setup.sh installs it)")
    tools = {name: find_tool(name, args.bin_dir, sub) for name, sub in
             (("guideway", "cli"), ("guidewayd", "daemon"), ("guideway-emulate", "simulators/emulators"),
              ("guideway-linuxcnc-bridge", "drivers/linuxcnc"))}
    user, why = loop_user()
    if not user:
        raise Skip(why)
    with machine_lock():
        others = lingering_linuxcnc()
        if others:
            raise Skip(f"a LinuxCNC this loop did not start runs here (pids {' '.join(others)}): starting another "
                       "would stop it")
        work = args.work or tempfile.mkdtemp(prefix="guideway-linuxcnc-loop-")
        os.makedirs(os.path.join(work, "run"), exist_ok=True)
        try:
            code, last_line = run_loop(args, tools, user, work)
        finally:
            if not args.keep and not args.work:
                shutil.rmtree(work, ignore_errors=True)
            else:
                say(f"kept {work} (the runs, the streams, LinuxCNC's configurations and logs, the report)")
        say(last_line)
        return code


def prepare_work(args, tools, user, work):
    """The work directory readable by LinuxCNC's user; the bridge copied there (a checkout may sit in a
    folder that user cannot enter)."""
    os.chmod(work, 0o755)
    bin_dir = os.path.join(work, "bin")
    os.makedirs(bin_dir, exist_ok=True)
    tools["guideway-linuxcnc-bridge"] = shutil.copy(tools["guideway-linuxcnc-bridge"], bin_dir)
    if os.getuid() == 0:  # LinuxCNC's user writes its socket there; guidewayd keeps its own in `work`
        shutil.chown(os.path.join(work, "run"), user)
    args.program = os.path.join(work, "dbb-test.ngc")
    res = subprocess.run([tools["guideway"], "program", "dbb", "--radius-mm", str(args.radius_mm),
                          "--feed-mm-per-min", str(args.feed_mm_per_min), "--center-mm",
                          *(str(c) for c in args.center_mm), "--out", args.program], capture_output=True, text=True)
    if res.returncode != 0:
        raise Failed(f"guideway program dbb: {res.stderr}")
    say(f"{elapsed()} {res.stderr.strip()}")


def run_loop(args, tools, user, work):
    share = os.path.abspath(args.share_dir)
    prepare_work(args, tools, user, work)
    daemon = Daemon(tools, work, args, os.path.join(work, "run", "linuxcnc.sock"))
    checks, switch_figures = [], {}
    try:
        before, stream_before, result_before, _ = measure("before", daemon, work, args, user, share)
        header_before, periods_before = check_stream("before", stream_before, result_before, checks)
        check_commanded("before", before, header_before, periods_before, checks)
        g_before = largest_g_um(before)
        say(f"{elapsed()} before: G {g_before:.2f} um")
        comp_dir = os.path.join(work, "comp")
        verify = ["--verify", "--machine", args.machine] if args.machine else []
        res = cli(tools, daemon.socket, "compensate", "dbb", "--latest", "--out-dir", comp_dir, *verify, timeout=300)
        say(res.stdout.rstrip())
        leave_out = [x for what, x in (("DO NOT ENTER", "squareness"),
                                       ("straightness.csv.do-not-load", "straightness")) if what in res.stdout]
        res = subprocess.run([tools["guideway"], "linuxcnc", "offsets", comp_dir,
                              *(a for x in leave_out for a in ("--leave-out", x))], capture_output=True, text=True)
        say(f"{elapsed()} guideway linuxcnc offsets {comp_dir}:\n{res.stdout.rstrip()}"
            if res.returncode == 0 else f"{elapsed()} no external offsets: {res.stderr.strip()}")
        after, stream_after, result_after, _ = measure("after", daemon, work, args, user, share, comp_dir)
        header, periods = check_stream("after", stream_after, result_after, checks)
        check_commanded("after", after, header, periods, checks)
        check_tables(header, periods, comp_dir, checks, switch_figures)
        check_offsets(header, periods, comp_dir, checks)
        g_after = largest_g_um(after)
        traced = (len(after.get("runs", [])), len(before.get("runs", [])))
        say(f"{elapsed()} after: {traced[0]} of the test's runs traced (before: {traced[1]})")
        checks.append(("after: every run of the test traced", traced[0] == traced[1] and traced[0] > 0))
        say(f"{elapsed()} the emulator {daemon.follower_status()}")
    finally:
        daemon.stop()
    report = os.path.join(work, "loop-report.html")
    runs = (tagged_copies(derived_runs(before), os.path.join(work, "runs-before"), "before") +
            tagged_copies(derived_runs(after), os.path.join(work, "runs-after"), "after"))
    res = subprocess.run([tools["guideway"], "report", *runs, "--out", report], capture_output=True, text=True)
    say(f"{elapsed()} report: {report}" if res.returncode == 0 else f"report failed: {res.stderr.strip()}")
    failed = [name for name, ok in checks if not ok]
    for name in failed:
        say(f"CHECK FAILED: {name}")
    figures = {"g_before_um": g_before, "g_after_um": g_after, "work": work, "checks": dict(checks), **switch_figures}
    if args.json:
        with open(args.json, "w") as f:
            json.dump(figures, f, indent=1)
    return 1 if failed else 0, (f"LinuxCNC loop: G before {g_before:.2f} µm, after {g_after:.2f} µm "
                                "(tables loaded by LinuxCNC)")


if __name__ == "__main__":
    sys.exit(main())
