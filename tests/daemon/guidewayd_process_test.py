#!/usr/bin/python3
"""guidewayd as a process: the CLI talks to it, systemd's notify protocol is spoken on a real
datagram socket (READY=1, WATCHDOG=1 driven by pipeline progress, STOPPING=1), SIGTERM ends it
cleanly and removes the socket, and a broken configuration is refused with file, line and key.
Usage: guidewayd_process_test.py BUILD_DIR"""
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import process_support  # noqa: E402


def wait_for(predicate, timeout=10.0):
    return process_support.wait_for(predicate, timeout, poll_s=0.02)


BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
# ctest runs the cases in two parts beside each other (tests/daemon/CMakeLists.txt): `--part lifecycle` the cases
# listed below (each starts and ends daemons and emulators: half the time under ASan), `--part rest` every
# other case. Without --part: all.
PART = sys.argv.pop(sys.argv.index("--part") + 1) if "--part" in sys.argv else None
if PART is not None:
    sys.argv.remove("--part")
LIFECYCLE = ("test_a_file_size_limit_is_a_refused_write_not_a_death",
             "test_an_emulator_that_exits_is_reaped_reported_and_restarted",
             "test_a_second_daemon_or_check_config_leaves_the_running_ones_endpoints_alone",
             "test_a_socket_directory_another_user_could_control_is_refused",
             "test_sd_notify_ready_watchdog_stopping")
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")


class GuidewaydProcess(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwp-")
        self.sock = os.path.join(self.tmp.name, "g.sock")

    def tearDown(self):
        self.tmp.cleanup()

    def isolated_env(self):
        """The environment with the state directory in the test's own tree: sessions these tests run
        must not add recordings to the user's (`guideway recordings` of a real daemon lists them)."""
        e = dict(os.environ)
        e.pop("STATE_DIRECTORY", None)
        e["XDG_STATE_HOME"] = os.path.join(self.tmp.name, "state")
        return e

    def start(self, *args, env=None, preexec_fn=None):
        e = self.isolated_env()
        e.pop("NOTIFY_SOCKET", None)
        e.update(env or {})
        p = subprocess.Popen([GUIDEWAYD, "--socket", self.sock, *args], env=e,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=preexec_fn)
        self.addCleanup(lambda: p.poll() is None and p.kill())
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock)), "daemon did not create its socket")
        return p

    def test_a_file_size_limit_is_a_refused_write_not_a_death(self):
        """Under `ulimit -f` a write past the limit raises SIGXFSZ, whose default action kills the process
        (the daemon died at 102,400 bytes of recording with every device and emulator): ignored, the
        write fails with EFBIG and is reported like a full disk; the daemon and the session go on."""
        import json
        import resource

        def limit():
            resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024))

        p = self.start(preexec_fn=limit)
        cli = lambda *a: subprocess.run([GUIDEWAY, "--socket", self.sock, *a], capture_output=True, text=True,
                                        timeout=30)
        self.assertTrue(wait_for(lambda: '"streaming"' in cli("status", "--json").stdout, 20))
        self.assertEqual(cli("start", "dbb").returncode, 0)

        def refused():
            st = json.loads(cli("status", "--json").stdout or "{}")
            return any("recording_error" in s for s in st.get("sessions", []))
        self.assertTrue(wait_for(refused, 40), "no recording_error while past the file-size limit")
        time.sleep(1.0)
        self.assertIsNone(p.poll(), "guidewayd died at the file-size limit")
        st = json.loads(cli("status", "--json").stdout)
        errors = [s["recording_error"] for s in st["sessions"] if "recording_error" in s]
        self.assertIn("too large", errors[0].lower())
        self.assertEqual({d["name"]: d["state"] for d in st["devices"]}["dbb"], "streaming")
        cli("stop")
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=30)

    def test_an_emulator_that_exits_is_reaped_reported_and_restarted(self):
        """An emulator child that dies was left a zombie, nothing logged, its device lost for good: now it
        is reaped, an EVENT and a log line say how it ended, and it is started again at the endpoint it
        served (the micrometer's Modbus TCP port, asked for as 0), so its device streams again."""
        import json
        p = self.start()
        cli = lambda *a: subprocess.run([GUIDEWAY, "--socket", self.sock, *a], capture_output=True, text=True,
                                        timeout=30)
        status = lambda: json.loads(cli("status", "--json").stdout or "{}")
        self.assertTrue(wait_for(lambda: all(d["state"] == "streaming" for d in status().get("devices", [{}])), 30))
        st = status()
        self.assertIn("emulators", st, st)
        gauge = next(e for e in st["emulators"] if e["name"] == "gauge")
        self.assertEqual(gauge["state"], "running")
        watcher = subprocess.Popen([GUIDEWAY, "--socket", self.sock, "watch", "--class", "EVENT", "--seconds", "20",
                                    "--json"], stdout=subprocess.PIPE, text=True)
        time.sleep(0.5)
        os.kill(gauge["pid"], signal.SIGKILL)

        def restarted():
            e = next(x for x in status()["emulators"] if x["name"] == "gauge")
            return e["restarts"] == 1 and e["state"] == "running"
        self.assertTrue(wait_for(restarted, 20), status()["emulators"])
        e = next(x for x in status()["emulators"] if x["name"] == "gauge")
        self.assertEqual(e["last_exit"], "killed by signal 9")
        self.assertEqual(e["endpoint"], gauge["endpoint"])  # the same port
        self.assertNotEqual(e["pid"], gauge["pid"])
        # No zombie under the daemon.
        with open(f"/proc/{p.pid}/task/{p.pid}/children") as f:
            children = [int(c) for c in f.read().split()]
        for c in children:
            with open(f"/proc/{c}/stat") as f:
                self.assertNotEqual(f.read().split(") ")[1][0], "Z", f"child {c} is a zombie")
        self.assertTrue(wait_for(lambda: {d["name"]: d["state"] for d in status()["devices"]}["micrometer"] == "streaming",
                                 20), status()["devices"])
        watcher.terminate()
        events = [json.loads(l) for l in watcher.communicate(timeout=10)[0].splitlines() if l.strip()]
        kinds = [(ev.get("emulator"), ev.get("event")) for ev in events]
        self.assertIn(("gauge", "emulator_exited"), kinds)
        self.assertIn(("gauge", "emulator_restarted"), kinds)
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=30)
        self.assertIn("emulator gauge exited (killed by signal 9)", err)
        self.assertIn("emulator gauge restarted", err)

    def test_a_socket_directory_another_user_could_control_is_refused(self):
        """With XDG_RUNTIME_DIR unset the daemon used /tmp/guideway-$UID whoever had made it: another user
        could create it first (0777) and serve a fake daemon, or plant the lock as a symlink. The default
        directory is created 0700; one that is world-writable, someone else's or a symlink is refused,
        the lock is not followed through a symlink, and the client refuses a socket another user owns."""
        import stat
        base = self.tmp.name

        def daemon_in(xdg, *extra):
            env = self.isolated_env()
            env.pop("NOTIFY_SOCKET", None)
            env["XDG_RUNTIME_DIR"] = xdg
            return subprocess.run([GUIDEWAYD, *extra], env=env, capture_output=True, text=True, timeout=30)

        # Created by the daemon: 0700.
        fresh = os.path.join(base, "fresh")
        os.makedirs(fresh)
        env = self.isolated_env()
        env.pop("NOTIFY_SOCKET", None)
        env["XDG_RUNTIME_DIR"] = fresh
        p = subprocess.Popen([GUIDEWAYD], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.addCleanup(lambda: p.poll() is None and p.kill())
        self.assertTrue(wait_for(lambda: os.path.exists(os.path.join(fresh, "guideway", "guideway.sock")), 20))
        self.assertEqual(stat.S_IMODE(os.stat(os.path.join(fresh, "guideway")).st_mode), 0o700)
        p.send_signal(signal.SIGTERM)
        p.communicate(timeout=30)

        # World-writable (as another user's mkdir with 0777 would leave it): refused.
        open_dir = os.path.join(base, "open")
        os.makedirs(os.path.join(open_dir, "guideway"))
        os.chmod(os.path.join(open_dir, "guideway"), 0o777)
        r = daemon_in(open_dir)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("refusing socket directory", r.stderr)
        self.assertIn("anyone can write to it", r.stderr)

        # A lock planted as a symlink is not followed.
        planted = os.path.join(base, "planted")
        os.makedirs(os.path.join(planted, "guideway"), mode=0o700)
        target = os.path.join(base, "victim-file")
        os.symlink(target, os.path.join(planted, "guideway", "guideway.sock.lock"))
        r = daemon_in(planted)
        self.assertNotEqual(r.returncode, 0)
        self.assertFalse(os.path.exists(target), "the daemon created a file through the planted symlink")

        if os.geteuid() != 0:
            self.skipTest("directories and sockets of another uid need root to create (the rest was checked)")
        # Another user's directory: refused.
        theirs = os.path.join(base, "theirs")
        os.makedirs(os.path.join(theirs, "guideway"), mode=0o700)
        os.chown(os.path.join(theirs, "guideway"), 12345, 12345)
        r = daemon_in(theirs)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("belongs to uid 12345", r.stderr)
        # The client refuses a socket another user owns (a fake daemon).
        fake = os.path.join(base, "fake.sock")
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        server.bind(fake)
        server.listen(1)
        os.chown(fake, 12345, 12345)
        c = subprocess.run([GUIDEWAY, "--socket", fake, "status"], capture_output=True, text=True, timeout=10)
        server.close()
        self.assertNotEqual(c.returncode, 0)
        self.assertIn("refusing a socket owned by uid 12345", c.stderr)

    def test_default_config_runs_and_cli_reports_status(self):
        p = self.start()
        out = subprocess.run([GUIDEWAY, "--socket", self.sock, "status"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("guidewayd", out.stdout)
        self.assertIn("<embedded default>", out.stdout)
        js = subprocess.run([GUIDEWAY, "--socket", self.sock, "status", "--json"], capture_output=True, text=True,
                            timeout=20)
        self.assertIn('"class":"STATUS"', js.stdout)
        p.send_signal(signal.SIGTERM)
        self.assertEqual(p.wait(timeout=10), 0)
        self.assertFalse(os.path.exists(self.sock), "socket left behind after SIGTERM")

    def test_cli_explains_when_no_daemon_runs(self):
        out = subprocess.run([GUIDEWAY, "--socket", self.sock, "status"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 1)
        self.assertIn("guideway:", out.stderr)
        self.assertIn(self.sock, out.stderr)

    def test_broken_config_is_refused_with_file_line_and_key(self):
        cfg = os.path.join(self.tmp.name, "bad.toml")
        with open(cfg, "w") as f:
            f.write("[daemon]\nlog_level = \"info\"\nstatus_period_s = -4\n")
        out = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 2)
        self.assertIn(cfg + ":3: daemon.status_period_s", out.stderr)
        ok = os.path.join(self.tmp.name, "ok.toml")
        with open(ok, "w") as f:
            f.write("[daemon]\nlog_level = \"debug\"\n")
        out = subprocess.run([GUIDEWAYD, "--config", ok, "--check-config"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 0, out.stderr)

    def guideway(self, *args):
        return subprocess.run([GUIDEWAY, *args], capture_output=True, text=True, timeout=30)

    def test_client_options_and_errors(self):
        """--socket after the command (README: every client command takes it), --json prints an ERROR
        reply unchanged on stdout, bad tcp: addresses and a bad --timeout are named before anything
        starts."""
        p = self.start()
        out = self.guideway("status", "--socket", self.sock)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("guidewayd", out.stdout)
        out = self.guideway("version", "-s", self.sock, "--json")
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn('"class":"VERSION"', out.stdout)
        out = self.guideway("params", "nosuch", "--json", "--socket", self.sock)
        self.assertEqual(out.returncode, 1)
        self.assertIn('"class":"ERROR"', out.stdout)
        self.assertIn('unknown session kind \\"nosuch\\"', out.stdout)
        self.assertIn("guideway: daemon: unknown session kind", out.stderr)
        out = self.guideway("params", "runout", "--socket", self.sock)
        self.assertEqual(out.returncode, 1)
        self.assertEqual(out.stdout, "")
        self.assertIn("guideway start runout", out.stderr)
        for address, why in (("tcp:127.0.0.1:abc", "port must be a number"), ("tcp:127.0.0.1:99999", "port must be"),
                             ("tcp:127.0.0.1", "expected tcp:HOST:PORT"), ("tcp::2947", "expected tcp:HOST:PORT")):
            out = self.guideway("--socket", address, "status")
            self.assertEqual(out.returncode, 1, address)
            self.assertIn(address + ": ", out.stderr)
            self.assertIn(why, out.stderr)
        out = self.guideway("start", "runout", "--wait", "--timeout", "-1", "--socket", self.sock)
        self.assertEqual(out.returncode, 1)
        self.assertIn("--timeout must be a positive number", out.stderr)
        out = self.guideway("start", "runout", "--set", "rpm", "--socket", self.sock)
        self.assertIn("--set expects KEY=VALUE", out.stderr)
        status = self.guideway("status", "--json", "--socket", self.sock)
        self.assertIn('"sessions":[]', status.stdout, "a refused start must not leave a session running")
        # watch: one readable line per message, or the daemon's JSON with --json.
        out = self.guideway("watch", "--class", "STATUS", "--count", "1", "--seconds", "20", "--socket", self.sock)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertRegex(out.stdout, r"^\d\d:\d\d:\d\d\.\d{3} STATUS  dbb:\w+ autocollimator:\w+")
        out = self.guideway("watch", "--class", "SAMPLE", "--channel", "dbb", "--count", "1", "--seconds", "20",
                            "--socket", self.sock)
        # In the units the rest of the tool speaks: a bar length and an axis position in mm (0.1 µm).
        self.assertRegex(out.stdout, r"SAMPLE  dbb seq \d+  bar_length=-?\d+\.\d{4} mm  x=-?\d+\.\d{4} mm")
        out = self.guideway("watch", "--class", "SAMPLE", "--channel", "dbb", "--count", "1", "--seconds", "20",
                            "--si", "--socket", self.sock)
        self.assertRegex(out.stdout, r"SAMPLE  dbb seq \d+  bar_length=[-0-9.e]+ m  x=[-0-9.e]+ m")
        out = self.guideway("watch", "--class", "STATUS", "--count", "1", "--seconds", "20", "--json", "--socket",
                            self.sock)
        self.assertTrue(out.stdout.startswith('{"class":"STATUS"'), out.stdout[:200])
        out = self.guideway("watch", "--class", "NOPE", "--json", "--socket", self.sock)
        self.assertEqual(out.returncode, 1)
        self.assertIn('"class":"ERROR"', out.stdout)
        # An array option (dbb's patterns) passes through --set as JSON.
        out = self.guideway("start", "dbb", "--set", 'patterns=[{"radius_mm":100,"height_mm":0,"direction":"ccw"}]',
                            "--socket", self.sock)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertTrue(wait_for(lambda: "/1 patterns traced" in self.guideway("status", "--socket", self.sock).stdout))
        self.assertEqual(self.guideway("stop", "--socket", self.sock).returncode, 0)
        p.send_signal(signal.SIGTERM)
        self.assertEqual(p.wait(timeout=10), 0)

    def test_replay_says_when_a_recording_is_not_a_whole_session(self):
        golden = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "golden", "runout.csv")
        with open(golden) as f:
            text = f.read()
        whole = self.guideway("replay", golden)
        self.assertEqual(whole.returncode, 0, whole.stderr)
        self.assertNotIn("incomplete", whole.stdout)
        self.assertNotIn("aborted", whole.stdout)
        aborted = os.path.join(self.tmp.name, "aborted.csv")  # what SIGTERM mid-session leaves
        with open(aborted, "w") as f:
            f.write(text.replace("# end = complete", "# end = aborted"))
        out = self.guideway("replay", aborted)
        self.assertIn("recording marked aborted", out.stdout)
        cut = os.path.join(self.tmp.name, "cut.csv.part")  # what SIGKILL leaves
        with open(cut, "w") as f:
            f.write(text[:text.index("# end =")])
        out = self.guideway("replay", cut)
        self.assertIn("incomplete recording", out.stdout + out.stderr)
        holed = os.path.join(self.tmp.name, "holed.csv")  # a disk that refused rows for long
        with open(holed, "w") as f:
            f.write(text.replace("# samples_lost = 0", "# samples_lost = 12"))
        out = self.guideway("replay", holed)
        self.assertIn("lost 12 samples", out.stdout)

    def test_docs_example_client_prints_published_params(self):
        """docs/example_client.py, as the docs run it, against the default (emulated) daemon."""
        example = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "example_client.py")
        p = self.start()
        client = subprocess.Popen(["/usr/bin/python3", example, self.sock], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        self.addCleanup(lambda: client.poll() is None and client.kill())
        self.assertIn("connected to guidewayd", client.stdout.readline())
        started = self.guideway("start", "profile", "--socket", self.sock)  # the next whole profile, < 5 s
        self.assertEqual(started.returncode, 0, started.stderr)
        session = started.stdout.split()[1]
        lines = []
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not any("profile.straightness_lsq_um" in l for l in lines):
            lines.append(client.stdout.readline())
        self.assertIn(f"{session} (profile, model", "".join(lines))
        self.assertTrue(any(l.strip().startswith("profile.straightness_lsq_um = ") and "+/-" in l for l in lines), lines)
        client.kill()
        p.send_signal(signal.SIGTERM)
        self.assertEqual(p.wait(timeout=10), 0)
        client.wait(timeout=10)
        self.assertEqual(client.stderr.read(), "")

    def test_a_second_daemon_or_check_config_leaves_the_running_ones_endpoints_alone(self):
        """The emulators' endpoints live in the socket's directory: a second guidewayd on the same socket
        (refused) and --check-config must not replace the running daemon's CAN socket and pty link,
        which its devices reconnect to."""
        p = self.start()
        can = os.path.join(self.tmp.name, "can-bus.sock")
        pty = os.path.join(self.tmp.name, "autocollimator.pty")
        self.assertTrue(wait_for(lambda: os.path.exists(can) and os.path.islink(pty)))
        before = (os.stat(can).st_ino, os.readlink(pty))
        second = subprocess.run([GUIDEWAYD, "--socket", self.sock], capture_output=True, text=True, timeout=30)
        self.assertEqual(second.returncode, 1)
        self.assertIn("another daemon is already listening on " + self.sock, second.stderr)
        self.assertNotIn("emulator", second.stderr)
        check = subprocess.run([GUIDEWAYD, "--socket", self.sock, "--check-config"], capture_output=True, text=True,
                               timeout=30)
        self.assertEqual(check.returncode, 0, check.stderr)
        self.assertIn("<embedded default>: OK (4 device(s))", check.stdout)
        self.assertEqual((os.stat(can).st_ino, os.readlink(pty)), before)
        out = self.guideway("status", "--socket", self.sock)
        self.assertEqual(out.returncode, 0, out.stderr)
        p.send_signal(signal.SIGTERM)
        self.assertEqual(p.wait(timeout=10), 0)

    def test_unknown_log_level_is_refused(self):
        out = subprocess.run([GUIDEWAYD, "--log-level", "loud", "--socket", self.sock], capture_output=True,
                             text=True, timeout=20)
        self.assertNotEqual(out.returncode, 0)
        self.assertIn("--log-level", out.stderr)
        self.assertFalse(os.path.exists(self.sock))

    def test_socket_group_and_tcp_host_are_checked_with_the_config(self):
        cfg = os.path.join(self.tmp.name, "group.toml")
        with open(cfg, "w") as f:
            f.write("[daemon]\nlog_level = \"info\"\nsocket_group = \"no-such-group-gw\"\n")
        out = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(cfg + ':3: daemon.socket_group: no group named "no-such-group-gw"', out.stderr)
        with open(cfg, "w") as f:
            f.write("[daemon]\ntcp_listen = \"localhost:2947\"\n")
        out = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(cfg + ':2: daemon.tcp_listen: HOST must be an IPv4 address', out.stderr)

    def check_config(self, *args):
        return subprocess.run([GUIDEWAYD, "--check-config", *args], capture_output=True, text=True, timeout=30)

    def test_check_config_refuses_what_the_daemon_would_fail_on(self):
        # A directory reads as an empty configuration: the daemon would run with no device, silently.
        out = self.check_config("--config", self.tmp.name)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(self.tmp.name + ": is a directory, not a configuration file", out.stderr)
        out = subprocess.run([GUIDEWAYD, "--config", self.tmp.name, "--socket", self.sock], capture_output=True,
                             text=True, timeout=20)
        self.assertEqual(out.returncode, 2, "the daemon itself refuses it too")
        self.assertFalse(os.path.exists(self.sock))

        # A Unix socket's address holds 107 bytes: too long a path is refused with its line, not at bind.
        long_path = "/tmp/" + "s" * 110 + ".sock"
        cfg = os.path.join(self.tmp.name, "long.toml")
        with open(cfg, "w") as f:
            f.write('[daemon]\nlog_level = "warn"\nsocket = "%s"\n' % long_path)
        out = self.check_config("--config", cfg)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(cfg + ":3: daemon.socket: socket path is 120 bytes; a Unix socket's address holds at most 107",
                      out.stderr)
        out = self.check_config("--socket", long_path)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn("--socket " + long_path + ": socket path is 120 bytes", out.stderr)

        # An emulator that will not start on its arguments is a configuration error (2), at its table.
        cfg = os.path.join(self.tmp.name, "emu.toml")
        with open(cfg, "w") as f:
            f.write('[daemon]\nlog_level = "warn"\n\n[[emulator]]\nname = "gauge"\ninstrument = "micrometer"\n'
                    'args = ["--no-such-option"]\n')
        out = self.check_config("--config", cfg)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(cfg + ':5: emulator "gauge": ', out.stderr)
        self.assertIn("--no-such-option", out.stderr, "the emulator's own words are passed on")

        # A reference to an emulator no table names is reported at the reference's own line.
        with open(cfg, "w") as f:
            f.write('[daemon]\nlog_level = "warn"\n\n[[emulator]]\nname = "gauge"\ninstrument = "micrometer"\n'
                    'args = ["--tcp", "127.0.0.1:0"]\n\n[[device]]\nname = "micrometer"\n'
                    'driver = "micrometer-modbus"\ntransport = "tcp"\nhost = "emulator:gauge:host"\n'
                    'port = "emulator:nope:port"\n')
        out = self.check_config("--config", cfg)
        self.assertEqual(out.returncode, 2, out.stdout)
        self.assertIn(cfg + ':14: device[0].port: "emulator:nope:port" names no [[emulator]] (known: gauge)',
                      out.stderr)

    def test_sd_notify_ready_watchdog_stopping(self):
        notify_path = os.path.join(self.tmp.name, "notify")
        ns = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        ns.bind(notify_path)
        ns.settimeout(10)
        self.addCleanup(ns.close)
        # WATCHDOG_PID must name the daemon: start it through a shell that execs, so the pid is known.
        cmd = f'WATCHDOG_PID=$$ exec "{GUIDEWAYD}" --socket "{self.sock}"'
        p = subprocess.Popen(["/bin/sh", "-c", cmd], env={**self.isolated_env(), "NOTIFY_SOCKET": notify_path,
                                                          "WATCHDOG_USEC": "200000"},
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.addCleanup(lambda: p.poll() is None and p.kill())
        seen = []
        deadline = time.monotonic() + 10
        watchdogs = 0
        while time.monotonic() < deadline and watchdogs < 3:
            msg = ns.recv(4096).decode()
            seen.append(msg)
            watchdogs += msg.count("WATCHDOG=1")
        self.assertTrue(any("READY=1" in m for m in seen), seen)
        self.assertGreaterEqual(watchdogs, 3, seen)
        p.send_signal(signal.SIGTERM)
        stopping = False
        while not stopping:
            msg = ns.recv(4096).decode()
            stopping = "STOPPING=1" in msg
        self.assertEqual(p.wait(timeout=10), 0)


def part_suite(part):
    names = unittest.TestLoader().getTestCaseNames(GuidewaydProcess)
    missing = [n for n in LIFECYCLE if n not in names]
    if missing or part not in ("lifecycle", "rest"):
        sys.exit(f"--part lifecycle|rest; LIFECYCLE names no case {missing}" if missing else f"unknown part {part}")
    return unittest.TestSuite(GuidewaydProcess(n) for n in names if (n in LIFECYCLE) == (part == "lifecycle"))


if __name__ == "__main__":
    if PART is None:
        unittest.main(verbosity=2)
    sys.exit(0 if unittest.TextTestRunner(verbosity=2).run(part_suite(PART)).wasSuccessful() else 1)
