#!/usr/bin/python3
"""guidewayd publishing to a real MQTT broker, and the fleet process storing it (Debian's mosquitto on a loopback port; docs/plant.md):
a DBB session's PARAMS arrives retained; the broker killed mid-session and restarted loses nothing
and keeps the order (the broker's stream equals what a socket client saw); messages queued while the
broker is down survive a restart of the daemon; a flood of EMCYs with the broker down leaves a session's
PARAMS and EXPLAIN in the journal (issue 46 item 2); a SIGKILLed daemon is shown offline by its will;
TLS with a password login works, and a wrong password is reported in STATUS and the log while the
daemon keeps running; the ACL of docs/plant.md refuses an impostor; a bad [mqtt] table is a config
error at its line. Then the plant: two daemons on different emulated machines and `guideway fleet
serve`; `guideway fleet status` lists both with their figures, a fleet restart stores nothing twice,
a killed daemon shows offline.
Usage: mqtt_daemon_test.py BUILD_DIR"""
import json
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import mqtt_broker  # noqa: E402
from process_support import guideway_cli, run_unittests, wait_for  # noqa: E402

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
EMULATE = os.path.join(BUILD, "simulators", "emulators", "guideway-emulate")
SKIP = mqtt_broker.missing()

SOURCE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
with open(os.path.join(SOURCE, "config", "dbb-node.toml")) as _f:
    # One circle (CCW, r = 100 mm, h = 0: the sessions here ask for that pattern), not Lai's three: 16 s a test.
    DBB_DEVICE = _f.read().replace('"--program", "standard"', '"--program", "single"').replace('"--pause-s", "1"', '"--pause-s", "0.5"')
assert '"single"' in DBB_DEVICE
PLANT_DOC = os.path.join(SOURCE, "docs", "plant.md")


class Daemon:
    """guidewayd with the DBB emulator and an [mqtt] table, in `directory`."""

    def __init__(self, directory, mqtt_table, name="d", daemon_table="", device=DBB_DEVICE):
        self.dir = directory
        self.sock = os.path.join(directory, name + ".sock")
        self.config = os.path.join(directory, name + ".toml")
        with open(self.config, "w") as f:
            f.write(f'[daemon]\nsocket = "{self.sock}"\nstate_dir = "{directory}/{name}-state"\nstatus_period_s = 0.5\n')
            f.write(daemon_table)
            f.write(device + "\n[mqtt]\n" + mqtt_table)
        self.log_path = os.path.join(directory, name + ".log")
        self.start()

    def start(self):
        self.log = open(self.log_path, "a")
        self.proc = subprocess.Popen([GUIDEWAYD, "--config", self.config], stdout=self.log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL)
        if not wait_for(lambda: self.proc.poll() is not None or self.answers(), timeout=30) or self.proc.poll() is not None:
            raise RuntimeError("guidewayd did not start:\n" + open(self.log_path).read())

    def answers(self):
        try:
            self.status()
            return True
        except Exception:
            return False

    def cli(self, *args, timeout=60):
        return guideway_cli(GUIDEWAY, self.sock, *args, timeout=timeout)

    def status(self):
        return json.loads(self.cli("status", "--json", timeout=5))

    def mqtt(self):
        return self.status()["mqtt"]

    def log_text(self):
        with open(self.log_path) as f:
            return f.read()

    def stop(self, sig=signal.SIGTERM):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            self.proc.wait(timeout=30)
        self.log.close()


class Watcher(threading.Thread):
    """A socket client watching PARAMS, EXPLAIN and EVENT: the stream the broker must match."""

    def __init__(self, sock_path):
        super().__init__(daemon=True)
        self.lines = []
        self.s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.s.connect(sock_path)
        self.s.sendall(b'{"class":"watch","classes":["PARAMS","EXPLAIN","EVENT"]}\n')
        self.f = self.s.makefile("rb")
        self.start()
        wait_for(lambda: self.watching, timeout=5)

    watching = False

    def run(self):
        for line in self.f:
            cls = json.loads(line)["class"]
            if cls == "WATCH":
                self.watching = True
            elif cls in ("PARAMS", "EXPLAIN", "EVENT"):
                self.lines.append(line.decode().rstrip("\n"))

    def close(self):
        self.s.close()


def results_and_events(messages, machine):
    """The PARAMS, EXPLAIN and EVENT payloads a subscriber got for `machine`, in order, a QoS 1
    redelivery (the same message twice in a row) counted once."""
    out = []
    for topic, payload in messages:
        parts = topic.split("/")
        if parts[1] == machine and parts[2] in ("params", "explain", "event") and (not out or out[-1] != payload):
            out.append(payload)
    return out


class BrokerCase(unittest.TestCase):
    """A temporary directory, and brokers, daemons and subscribers in it, stopped after the test."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwmq-")
        self.d = self.tmp.name
        self.cleanup = []

    def tearDown(self):
        for c in reversed(self.cleanup):
            c()
        self.tmp.cleanup()

    def broker(self, **kw):
        b = mqtt_broker.Broker(self.d, **kw)
        self.cleanup.append(b.stop)
        return b

    def daemon(self, table, name="d", daemon_table=""):
        d = Daemon(self.d, table, name, daemon_table)
        self.cleanup.append(d.stop)
        return d

    def subscriber(self, broker, topic, name, **kw):
        s = mqtt_broker.Subscriber(broker, topic, os.path.join(self.d, name + ".sub"), **kw)
        self.cleanup.append(s.stop)
        return s


@unittest.skipIf(SKIP, SKIP)
class MqttPublishing(BrokerCase):
    def test_a_broker_killed_mid_session_loses_nothing_and_keeps_the_order(self):
        broker = self.broker(persistence=True)
        sub = self.subscriber(broker, "guideway/#", "all", client_id="order-check")
        broker.wait_saved("order-check")  # the subscriber's session outlives the kill
        d = self.daemon(f'broker = "mqtt://127.0.0.1:{broker.port}"\nmachine = "mill-1"\n')
        self.assertTrue(wait_for(lambda: d.mqtt()["state"] == "connected", timeout=10), d.mqtt())
        watcher = Watcher(d.sock)
        self.cleanup.append(watcher.close)
        session = subprocess.Popen([GUIDEWAY, "--socket", d.sock, "start", "dbb", "--set",
                                    'patterns=[{"radius_mm":100,"height_mm":0,"direction":"ccw"}]', "--set", "feed_mm_per_min=5000", "--wait", "--json",
                                    "--timeout", "120"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.assertTrue(wait_for(lambda: any('"session_started"' in l or '"recording"' in l for l in watcher.lines)
                                 or d.status()["sessions"], timeout=10))
        broker.kill()  # mid-session: the session goes on, its results wait in the journal
        out, err = session.communicate(timeout=150)
        self.assertEqual(session.returncode, 0, err)
        self.assertTrue(wait_for(lambda: any('"report_ready"' in l for l in watcher.lines), timeout=60), watcher.lines)
        m = d.mqtt()
        self.assertEqual(m["state"], "disconnected", m)
        self.assertGreaterEqual(m["queued"], 3, m)  # PARAMS, EXPLAIN, report_ready at least
        self.assertIn("MQTT: connection to", d.log_text())
        human = d.cli("status")
        self.assertRegex(human, r"mqtt: disconnected \(mqtt://127.0.0.1:\d+, machine mill-1, since .*\), [1-9]\d* queued")
        self.assertIn("last error: ", human)
        self.assertTrue(os.listdir(os.path.join(self.d, "d-state", "mqtt-journal")))

        broker.start()
        self.assertTrue(wait_for(lambda: d.mqtt()["queued"] == 0 and d.mqtt()["state"] == "connected", timeout=90),
                        d.mqtt())
        self.assertEqual(d.mqtt()["dropped"], 0)
        seen = watcher.lines
        self.assertTrue(wait_for(lambda: results_and_events(sub.messages(), "mill-1")[-len(seen):] == seen, timeout=15),
                        "the broker's stream differs from the socket's:\nsocket: %s\nbroker: %s"
                        % ("\n".join(x[:100] for x in seen),
                           "\n".join(x[:100] for x in results_and_events(sub.messages(), "mill-1"))))
        kinds = [json.loads(x)["class"] for x in seen]
        self.assertIn("PARAMS", kinds)
        self.assertIn("EXPLAIN", kinds)

        # Retained: a subscriber that comes later gets the latest PARAMS and EXPLAIN at once.
        params = [x for x in seen if json.loads(x)["class"] == "PARAMS"][-1]
        self.assertEqual(mqtt_broker.retained(broker, "guideway/mill-1/params/dbb"), params)
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-1/explain/dbb"))["class"], "EXPLAIN")
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-1/status"))["state"], "online")
        devices = [p for t, p in sub.messages() if t == "guideway/mill-1/devices"]
        self.assertTrue(devices and json.loads(devices[-1])["devices"][0]["name"] == "dbb")

        # Killed: the broker's will says offline.
        d.stop(signal.SIGKILL)
        self.assertTrue(wait_for(lambda: json.loads(mqtt_broker.retained(broker, "guideway/mill-1/status") or "{}")
                                 .get("state") == "offline", timeout=10))
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-1/status"))["reason"], "connection lost")

    def test_messages_queued_while_the_broker_is_down_survive_a_daemon_restart(self):
        broker = self.broker(persistence=True)
        sub = self.subscriber(broker, "guideway/+/event", "events", client_id="restart-check")
        broker.wait_saved("restart-check")
        broker.kill()
        d = self.daemon(f'broker = "mqtt://127.0.0.1:{broker.port}"\nmachine = "mill-2"\nreconnect_max_s = 2\n')
        self.assertTrue(wait_for(lambda: d.mqtt()["queued"] >= 1, timeout=10), d.mqtt())  # "streaming" and the like
        queued_seen = d.mqtt()["queued"]
        journal = os.path.join(self.d, "d-state", "mqtt-journal")
        d.stop()  # SIGTERM, broker still down: the messages stay on disk
        # Counted on disk: more may be queued between the STATUS above and the stop (the device's events come
        # as it starts streaming; a run beside a bench counted one more).
        first_run = len(os.listdir(journal))
        self.assertGreaterEqual(first_run, queued_seen)
        self.assertIn("stay in", d.log_text())
        broker.start()
        d.start()
        self.assertIn(f"{first_run} message(s) left unsent by the last run are queued", d.log_text())
        self.assertTrue(wait_for(lambda: d.mqtt()["queued"] == 0 and d.mqtt()["delivered"] >= first_run, timeout=30),
                        d.mqtt())
        events = wait_for(lambda: [json.loads(p) for t, p in sub.messages() if t == "guideway/mill-2/event"]
                          if len(sub.messages()) >= first_run + 1 else None, timeout=15)
        self.assertTrue(events, sub.messages())
        # The first run's events come first, in order (both runs report the device streaming).
        self.assertEqual([e["event"] for e in events[:first_run]].count("streaming"), 1, events)
        self.assertEqual(os.listdir(journal), [])

    def test_a_sessions_results_survive_an_emcy_flood_with_the_broker_down(self):
        """Issue 46 item 2: broker down, queue_max_messages = 100, a session, then 150 EMCYs of one node:
        the session's PARAMS and EXPLAIN stay in the journal and reach the broker when it is back."""
        broker = self.broker()
        broker.kill()
        can = os.path.join(self.d, "can.sock")
        emulator = subprocess.Popen([EMULATE, "dbb", "--bus", "unix:" + can, "--program", "single", "--feed-mm-min",
                                     "5000", "--pause-s", "0.5"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, text=True, bufsize=1)

        def stop_emulator():
            emulator.kill()
            emulator.wait()
            emulator.stdin.close()
            emulator.stdout.close()
        self.cleanup.append(stop_emulator)
        self.assertEqual(emulator.stdout.readline().strip(), "bus: unix:" + can)
        self.assertEqual(emulator.stdout.readline().strip(), "endpoint: unix:" + can)
        device = DBB_DEVICE[DBB_DEVICE.index("[[device]]"):].replace('"emulator:can"', '"unix:%s"' % can)
        d = Daemon(self.d, f'broker = "mqtt://127.0.0.1:{broker.port}"\nmachine = "mill-6"\n'
                   'queue_max_messages = 100\nreconnect_max_s = 2\n', name="flood", device=device)
        self.cleanup.append(d.stop)
        self.assertTrue(wait_for(lambda: d.status()["devices"][0]["state"] == "streaming", timeout=30), d.status())
        out = d.cli("start", "dbb", "--set", 'patterns=[{"radius_mm":100,"height_mm":0,"direction":"ccw"}]',
                    "--set", "feed_mm_per_min=5000", "--wait", "--json", "--timeout", "120", timeout=150)
        session = json.loads(out.splitlines()[-1])["session"]
        journal = os.path.join(self.d, "flood-state", "mqtt-journal")

        def journaled():
            found = []
            for name in sorted(os.listdir(journal)):
                try:
                    with open(os.path.join(journal, name), "rb") as f:
                        payload = f.read().split(b"\n", 4)[4]
                except (OSError, IndexError):
                    continue  # sent meanwhile, or a .part
                message = json.loads(payload)
                found.append((message["class"], message.get("session", ""), message.get("event", "")))
            return found

        self.assertTrue(wait_for(lambda: ("EXPLAIN", session, "") in journaled(), timeout=120), journaled())
        for _ in range(150):
            emulator.stdin.write("emcy 1 0x8130 0x11\n")
            emulator.stdin.flush()
            reply = emulator.stdout.readline()
            self.assertTrue(reply.startswith("ok"), reply)
        self.assertTrue(wait_for(lambda: d.status()["devices"][0]["driver_counters"]["emcy"] >= 150, timeout=30),
                        d.status()["devices"][0]["driver_counters"])
        self.assertTrue(wait_for(lambda: [e for e in journaled() if e[2] == "node_emcy"], timeout=10))
        time.sleep(1)  # the publisher's thread takes what was handed over
        left = journaled()
        self.assertIn(("PARAMS", session, ""), left)
        self.assertIn(("EXPLAIN", session, ""), left)
        self.assertLessEqual(len(left), 100)
        self.assertLessEqual(sum(1 for e in left if e[2] in ("node_emcy", "events_dropped")), 25, left)
        m = d.mqtt()
        self.assertEqual((m["dropped_results"], m["dropped_transitions"]), (0, 0), m)
        self.assertGreater(m["rate_limited"], 0, m)

        broker.start()
        self.assertTrue(wait_for(lambda: d.mqtt()["queued"] == 0, timeout=60), d.mqtt())
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-6/params/dbb"))["session"], session)
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-6/explain/dbb"))["session"], session)
        # The held-back EMCYs are counted in events_dropped EVENTs (the log says so too).
        self.assertIn("held back: more than 60 a minute", d.log_text())

    def test_tls_with_a_password_and_a_wrong_password(self):
        ca, cert, key = mqtt_broker.make_certificates(self.d)
        broker = self.broker(tls=(ca, cert, key), users={"mill-3": "s3cret"})
        good = os.path.join(self.d, "good.pw")
        bad = os.path.join(self.d, "bad.pw")
        for path, pw in ((good, "s3cret\n"), (bad, "wrong\n")):
            with open(path, "w") as f:
                f.write(pw)
            os.chmod(path, 0o600)
        table = 'broker = "mqtts://127.0.0.1:{}"\nca_file = "{}"\nusername = "mill-3"\npassword_file = "{}"\nmachine = "{}"\n'
        d = self.daemon(table.format(broker.port, ca, good, "mill-3"), "good")
        self.assertTrue(wait_for(lambda: d.mqtt()["state"] == "connected", timeout=15), d.mqtt())
        tls = ["--cafile", ca, "-u", "mill-3", "-P", "s3cret"]
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-3/status", tls))["state"], "online")

        wrong = self.daemon(table.format(broker.port, ca, bad, "mill-4"), "wrong")
        self.assertTrue(wait_for(lambda: wrong.mqtt()["state"] == "refused", timeout=15), wrong.mqtt())
        d.stop()  # a clean stop: offline at once, and no "connection lost" in its log
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-3/status", tls))["reason"], "stopped")
        self.assertNotIn("connection to", d.log_text())
        m = wrong.mqtt()
        self.assertRegex(m["last_error"].lower(), "not authori[sz]ed|bad user name or password", m)
        time.sleep(3)  # retries with back-off, logs once, keeps serving
        self.assertEqual(wrong.proc.poll(), None)
        self.assertEqual(wrong.mqtt()["state"], "refused")
        log = wrong.log_text()
        self.assertEqual(log.count("refused the connection"), 1, log)
        self.assertIn('user "mill-3"', log)

    def test_the_acl_of_docs_plant_md_keeps_each_machine_to_its_own_topics(self):
        with open(PLANT_DOC) as f:
            doc = f.read()
        acl = re.search(r"```acl\n(.*?)```", doc, re.S).group(1)
        broker = self.broker(users={"mill-5": "pw5", "historian": "pwh"}, acl=acl)
        pw = os.path.join(self.d, "mill-5.pw")
        with open(pw, "w") as f:
            f.write("pw5\n")
        os.chmod(pw, 0o600)
        table = f'broker = "mqtt://127.0.0.1:{broker.port}"\nusername = "mill-5"\npassword_file = "{pw}"\n'
        own = self.daemon(table + 'machine = "mill-5"\n', "own")
        self.assertTrue(wait_for(lambda: own.mqtt()["delivered"] >= 1 and own.mqtt()["queued"] == 0, timeout=15),
                        own.mqtt())
        self.assertEqual(own.mqtt()["refused"], 0)
        reader = ["-u", "historian", "-P", "pwh"]
        self.assertEqual(json.loads(mqtt_broker.retained(broker, "guideway/mill-5/status", reader))["state"], "online")
        # A daemon that logs in as mill-5 but calls itself mill-6 may not write there: refused, and said.
        other = self.daemon(table + 'machine = "mill-6"\nclient_id = "guidewayd-impostor"\n', "other")
        self.assertTrue(wait_for(lambda: other.mqtt()["refused"] >= 1, timeout=15), other.mqtt())
        self.assertEqual(other.mqtt()["delivered"], 0)
        self.assertRegex(other.log_text(), "refused the message on guideway/mill-6/.*Not authori[sz]ed.*ACL")
        self.assertIsNone(mqtt_broker.retained(broker, "guideway/mill-6/status", reader))
        self.assertEqual(own.mqtt()["state"], "connected")

    def test_bad_mqtt_tables_are_config_errors_at_their_line(self):
        pw = os.path.join(self.d, "open.pw")
        with open(pw, "w") as f:
            f.write("x\n")
        os.chmod(pw, 0o644)
        writable = os.path.join(self.d, "writable.pw")
        with open(writable, "w") as f:
            f.write("x\n")
        os.chmod(writable, 0o602)
        path_of_text = pw
        cases = [
            ('broker = "http://broker:1883"\n', "mqtt.broker", "unknown scheme"),
            ('broker = "mqtt://broker:99999"\n', "mqtt.broker", "port"),
            ('broker = "mqtt://b"\nmachine = "cell/3"\n', "mqtt.machine", "'/'"),
            ('broker = "mqtt://b"\npassword = "x"\n', "mqtt.password", "password_file"),
            (f'broker = "mqtt://b"\nusername = "u"\npassword_file = "{pw}"\n', "mqtt.password_file", "every user"),
            (f'broker = "mqtt://b"\nca_file = "{pw}"\n', "mqtt.ca_file", "mqtts://"),
            ('broker = "mqtts://b"\nca_file = "/nonexistent/ca.pem"\n', "mqtt.ca_file", "cannot read"),
            # What --check-config passed and the daemon then died on, or printed raw to a terminal.
            (f'broker = "mqtts://b"\nca_file = "{self.d}"\n', "mqtt.ca_file", "is a directory"),
            (f'broker = "mqtts://b"\nca_file = "{path_of_text}"\n', "mqtt.ca_file", "no PEM certificate"),
            (f'broker = "mqtt://b"\nusername = "u"\npassword_file = "{writable}"\n', "mqtt.password_file",
             "written by every user"),
            ('broker = "mqtt://::1"\n', "mqtt.broker", "between brackets"),
            ('broker = "mqtt://bro ker"\n', "mqtt.broker", "letters, digits"),
            ('broker = "mqtt://b"\nmachine = "a\\u001bb"\n', "mqtt.machine", "control characters"),
            ('broker = "mqtt://b"\nmachine = "' + "m" * 70000 + '"\n', "mqtt.machine", "at most 128"),
            ('broker = "mqtt://b"\nclient_id = "' + "c" * 70000 + '"\n', "mqtt.client_id", "at most 256"),
            ('broker = "mqtt://b"\n', "daemon.state_dir", "MQTT journal", '[daemon]\nstate_dir = "/etc/passwd/state"\n'),
            ('broker = "mqtt://b"\nqueue_events_percent = 0\n', "mqtt.queue_events_percent", "[1, 100]"),
            ('broker = "mqtt://b"\nevents_per_minute = 1e9\n', "mqtt.events_per_minute", "60000"),
        ]
        for table, key, words, *daemon_table in cases:
            path = os.path.join(self.d, "bad.toml")
            with open(path, "w") as f:
                f.write((daemon_table[0] if daemon_table else '[daemon]\nlog_level = "info"\n') + '\n[mqtt]\n' + table)
            out = subprocess.run([GUIDEWAYD, "--config", path, "--check-config"], capture_output=True, text=True)
            self.assertEqual(out.returncode, 2, (table, out.stdout, out.stderr))
            self.assertIn(key, out.stderr, table)
            self.assertIn(words, out.stderr, table)
            self.assertRegex(out.stderr, r"bad\.toml:\d+", table)


@unittest.skipIf(SKIP, SKIP)
class FleetServe(BrokerCase):
    """The issue's plant on one machine: a broker, two daemons on emulated machine tools with different
    errors, `guideway fleet serve`; `guideway fleet status` lists both with their figures."""

    def fleet(self, broker, db):
        log = open(os.path.join(self.d, "fleet.log"), "a")
        proc = subprocess.Popen([GUIDEWAY, "fleet", "serve", "--broker", f"mqtt://127.0.0.1:{broker.port}", "--db", db],
                                stdout=log, stderr=subprocess.STDOUT)

        def stop():
            if proc.poll() is None:
                proc.terminate()
                self.assertEqual(proc.wait(timeout=20), 0)
            log.close()
        self.cleanup.append(stop)
        return proc, stop

    def fleet_log(self):
        with open(os.path.join(self.d, "fleet.log")) as f:
            return f.read()

    def fleet_status(self, db):
        out = subprocess.run([GUIDEWAY, "fleet", "status", "--db", db, "--json"], capture_output=True, text=True)
        return json.loads(out.stdout) if out.returncode == 0 else {"machines": []}

    def test_two_daemons_and_the_fleet_view(self):
        broker = self.broker(persistence=True)
        db = os.path.join(self.d, "fleet.sqlite")
        proc, stop_fleet = self.fleet(broker, db)
        machines = os.path.join(SOURCE, "config")
        daemons = {}
        for name, machine_file in (("mill-1", "machine-example.toml"), ("mill-2", "machine-leadscrew.toml")):
            daemons[name] = self.daemon(f'broker = "mqtt://127.0.0.1:{broker.port}"\nmachine = "{name}"\n', name,
                                        f'emulator_machine = "{machines}/{machine_file}"\n')
        # One waits with its progress on stderr, the other with --quiet.
        sessions = [subprocess.Popen([GUIDEWAY, "--socket", d.sock, "start", "dbb", "--set",
                                      'patterns=[{"radius_mm":100,"height_mm":0,"direction":"ccw"}]', "--set", "feed_mm_per_min=5000", "--wait",
                                      "--timeout", "120", *(["--quiet"] if i else [])],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                    for i, d in enumerate(daemons.values())]
        for i, p in enumerate(sessions):
            out, err = p.communicate(timeout=150)
            self.assertEqual(p.returncode, 0, err)
            self.assertIn("session", out)
            if i:
                self.assertEqual(err, "", "--quiet prints no progress")
            else:
                self.assertRegex(err, r"\[\d+ s\] running: 0/1 patterns traced", "progress while the session runs")

        def both_listed():
            st = self.fleet_status(db)
            rows = {m["machine"]: m for m in st["machines"]}
            return rows if all(n in rows and "dbb" in rows[n].get("latest", {}) and "dbb" in rows[n].get("explain", {})
                               for n in daemons) else None
        rows = wait_for(both_listed, timeout=60)
        self.assertTrue(rows, self.fleet_status(db))
        g = {}
        for name in daemons:
            self.assertEqual(rows[name]["state"], "online")
            figures = {f["name"]: f for f in rows[name]["latest"]["dbb"]["figures"]}
            self.assertIn("circular_deviation_um", figures, figures)
            g[name] = figures["circular_deviation_um"]["value"]
            self.assertLess(rows[name]["dbb_age_s"], 300)
        self.assertNotAlmostEqual(g["mill-1"], g["mill-2"], delta=0.5)  # different machines, different errors
        # What the fleet stored is what the daemon published.
        params = json.loads(daemons["mill-2"].cli("params", "dbb", "--json"))
        hist = json.loads(subprocess.run([GUIDEWAY, "fleet", "history", "mill-2", "--db", db, "--json"],
                                         capture_output=True, text=True, check=True).stdout)
        self.assertIn(params["session"], json.dumps(hist))
        human = subprocess.run([GUIDEWAY, "fleet", "status", "--db", db], capture_output=True, text=True, check=True).stdout
        self.assertRegex(human, r"(?m)^mill-1 +online")
        self.assertRegex(human, r"(?m)^mill-2 +online")

        # The fleet restarted: the retained results arrive again and are not stored twice.
        before = len(hist["results"])
        stop_fleet()
        proc, stop_fleet = self.fleet(broker, db)
        self.assertTrue(wait_for(lambda: "subscribed to guideway/#" in self.fleet_log().split("storing into")[-1],
                                 timeout=15))
        time.sleep(1)
        hist2 = json.loads(subprocess.run([GUIDEWAY, "fleet", "history", "mill-2", "--db", db, "--json"],
                                          capture_output=True, text=True, check=True).stdout)
        self.assertEqual(len(hist2["results"]), before)

        # A daemon killed: the fleet shows it offline.
        daemons["mill-1"].stop(signal.SIGKILL)
        self.assertTrue(wait_for(lambda: {m["machine"]: m for m in self.fleet_status(db)["machines"]}["mill-1"]["state"]
                                 == "offline", timeout=15))


if __name__ == "__main__":
    run_unittests()
