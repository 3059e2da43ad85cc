#!/usr/bin/python3
"""The fleet loses nothing the broker acknowledged (docs/plant.md, "Delivery"): `guideway fleet serve`
against Debian's mosquitto, with a flood of PARAMS published at QoS 1 by mosquitto_pub (every message
it sent was acknowledged by the broker when it exits 0):
- SIGKILLed at 20+ random points of the flood and restarted each time: afterwards every message is in
  the database exactly once;
- its database on a full file system (a small tmpfs filled up; where mounting is not allowed, a file
  size limit, which fails writes the same way): nothing stored, nothing acknowledged, and once space is
  freed every message is stored, without a restart;
- its database locked by another process for longer than the busy timeout: stored when the lock goes;
- a clean SIGTERM: exit 0 and no "connection lost" in its log;
- over TLS (the broker's certificate checked against --ca-file and its address) with a password login;
  a wrong password and a foreign CA are said in the log and retried; a CA file that is not one is
  refused at start.
Usage: fleet_delivery_test.py BUILD_DIR"""
import os
import random
import resource
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import mqtt_broker  # noqa: E402
from process_support import run_unittests, wait_for  # noqa: E402

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
SKIP = mqtt_broker.missing()
TOPIC = "guideway/mill-1/params/dbb"


def payload(i, tag):
    return '{"class":"PARAMS","machine":"mill-1","session":"%s-%05d"}' % (tag, i)


def stored_sessions(db, tag):
    """The session names of `tag` in the database, with repeats (a message stored twice shows twice)."""
    if not os.path.exists(db):
        return []
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=10) as c:
            return [r[0] for r in c.execute("SELECT session FROM results WHERE session LIKE ?", (tag + "-%",))]
    except sqlite3.OperationalError:
        return []


class Publisher:
    """mosquitto_pub -l at QoS 1: one message per line written; exit 0 once the broker acknowledged all."""

    def __init__(self, broker, log):
        self.proc = subprocess.Popen(["mosquitto_pub", "-V", "mqttv5", "-h", "127.0.0.1", "-p", str(broker.port),
                                      "-q", "1", "-t", TOPIC, "-l", "-i", "flood-%d" % os.getpid()],
                                     stdin=subprocess.PIPE, stdout=log, stderr=subprocess.STDOUT, text=True)

    def send(self, line):
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def finish(self):
        self.proc.stdin.close()
        return self.proc.wait(timeout=60)


@unittest.skipIf(SKIP, SKIP)
class FleetDelivery(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwfd-")
        self.d = self.tmp.name
        self.log_path = os.path.join(self.d, "fleet.log")
        self.procs = []
        self.mounts = []
        # The broker queues for the fleet while it is down; docs/plant.md's setting (mosquitto's 1000 drops).
        self.broker = mqtt_broker.Broker(self.d, extra_conf=("max_queued_messages 100000",))

    def tearDown(self):
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        self.broker.stop()
        for mnt in self.mounts:
            subprocess.run(["umount", "-l", mnt])
        self.tmp.cleanup()

    def fleet(self, db, fsize_limit=None):
        log = open(self.log_path, "a")
        if not fsize_limit:
            p = subprocess.Popen([GUIDEWAY, "fleet", "serve", "--broker", f"mqtt://127.0.0.1:{self.broker.port}",
                                  "--db", db], stdout=log, stderr=subprocess.STDOUT)
            log.close()
        else:  # the limit holds for every file it writes: its log goes through a pipe
            p = subprocess.Popen([GUIDEWAY, "fleet", "serve", "--broker", f"mqtt://127.0.0.1:{self.broker.port}",
                                  "--db", db], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_limit, fsize_limit)))

            def copy():
                for line in p.stdout:
                    log.write(line.decode(errors="replace"))
                    log.flush()
                log.close()
            threading.Thread(target=copy, daemon=True).start()
        self.procs.append(p)
        return p

    def log(self):
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def wait_subscribed(self, times):
        self.assertTrue(wait_for(lambda: self.log().count("subscribed to guideway/#") >= times, timeout=30), self.log())

    def test_killed_at_random_points_of_a_flood_it_stores_every_acknowledged_message_once(self):
        db = os.path.join(self.d, "fleet.sqlite")
        fleet = self.fleet(db)
        self.wait_subscribed(1)  # the persistent session exists: the broker queues for it from now on
        pub_log = open(os.path.join(self.d, "pub.log"), "w")
        pub = Publisher(self.broker, pub_log)
        rng = random.Random(int(os.environ.get("GUIDEWAY_TEST_SEED", "20261127")))
        sent = kills = 0
        next_kill = time.monotonic() + rng.uniform(0.05, 0.4)
        while kills < 20:
            pub.send(payload(sent, "flood"))
            sent += 1
            time.sleep(0.002)
            if time.monotonic() >= next_kill:
                fleet.send_signal(signal.SIGKILL)  # mid-batch, mid-connect, between commit and PUBACK: anywhere
                fleet.wait()
                kills += 1
                fleet = self.fleet(db)
                next_kill = time.monotonic() + rng.uniform(0.05, 0.4)
        for _ in range(200):
            pub.send(payload(sent, "flood"))
            sent += 1
        self.assertEqual(pub.finish(), 0, "mosquitto_pub: the broker did not acknowledge everything")
        pub_log.close()
        expected = {"flood-%05d" % i for i in range(sent)}
        self.assertTrue(wait_for(lambda: len(stored_sessions(db, "flood")) >= sent, timeout=90),
                        f"{len(stored_sessions(db, 'flood'))} of {sent} stored\n" + self.log()[-3000:])
        got = stored_sessions(db, "flood")
        self.assertEqual(set(got), expected, f"missing: {sorted(expected - set(got))[:10]}")
        self.assertEqual(len(got), len(expected), "a message was stored twice")
        print(f"{sent} messages, {kills} kills of fleet serve: all stored once", file=sys.stderr)
        fleet.terminate()
        self.assertEqual(fleet.wait(timeout=20), 0)
        self.assertNotIn("connection lost", self.log().split("stored ")[-1])

    def full_file_system(self):
        """A 2 MB tmpfs (root, mount allowed), or None."""
        if os.geteuid() != 0:
            return None
        mnt = os.path.join(self.d, "small")
        os.mkdir(mnt)
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", mnt], capture_output=True).returncode != 0:
            os.rmdir(mnt)
            return None
        self.mounts.append(mnt)
        return mnt

    def test_a_full_disk_acknowledges_nothing_and_everything_is_stored_once_space_is_back(self):
        mnt = self.full_file_system()
        db = os.path.join(mnt or self.d, "fleet.sqlite")
        fleet = self.fleet(db)
        self.wait_subscribed(1)
        pub_log = open(os.path.join(self.d, "pub.log"), "w")
        pub = Publisher(self.broker, pub_log)
        pub.send(payload(0, "warm"))
        self.assertTrue(wait_for(lambda: len(stored_sessions(db, "warm")) == 1, timeout=20), self.log())
        if mnt:  # fill what is left
            filler = os.path.join(mnt, "filler")
            with open(filler, "wb") as f:
                try:
                    while True:
                        f.write(b"\0" * 65536)
                        f.flush()
                except OSError:
                    pass
        else:  # no mount here: a file size limit fails the database's writes the same way (EFBIG)
            fleet.terminate()
            fleet.wait(timeout=20)
            fleet = self.fleet(db, fsize_limit=1)
            self.wait_subscribed(2)
        for i in range(300):
            pub.send(payload(i, "full"))
        self.assertEqual(pub.finish(), 0)
        pub_log.close()
        self.assertTrue(wait_for(lambda: "could not store" in self.log(), timeout=30), self.log())
        time.sleep(1)
        self.assertEqual(stored_sessions(db, "full"), [])
        self.assertEqual(fleet.poll(), None, "fleet serve died on a full disk:\n" + self.log())
        if mnt:
            os.remove(filler)  # space is back: the fleet's next retry stores the batch it holds
        else:
            fleet.terminate()
            fleet.wait(timeout=20)
            fleet = self.fleet(db)
        self.assertTrue(wait_for(lambda: len(stored_sessions(db, "full")) >= 300, timeout=60),
                        f"{len(stored_sessions(db, 'full'))} of 300 stored\n" + self.log()[-3000:])
        got = stored_sessions(db, "full")
        self.assertEqual(sorted(got), ["full-%05d" % i for i in range(300)])
        print(f"full disk ({'tmpfs' if mnt else 'RLIMIT_FSIZE'}): 0 stored while full, 300 of 300 after",
              file=sys.stderr)

    def test_a_database_locked_past_the_busy_timeout_loses_nothing(self):
        db = os.path.join(self.d, "fleet.sqlite")
        self.fleet(db)
        self.wait_subscribed(1)
        locker = sqlite3.connect(db, isolation_level=None, timeout=10)
        locker.execute("BEGIN EXCLUSIVE")  # a backup, a long admin query: the writer waits 5 s, then fails
        pub_log = open(os.path.join(self.d, "pub.log"), "w")
        pub = Publisher(self.broker, pub_log)
        for i in range(5):
            pub.send(payload(i, "locked"))
        self.assertEqual(pub.finish(), 0)
        pub_log.close()
        self.assertTrue(wait_for(lambda: "could not store" in self.log(), timeout=20), self.log())
        locker.execute("COMMIT")
        locker.close()
        self.assertTrue(wait_for(lambda: len(stored_sessions(db, "locked")) >= 5, timeout=40), self.log())
        self.assertEqual(sorted(stored_sessions(db, "locked")), ["locked-%05d" % i for i in range(5)])
        # The rows are visible before the line that says so is written (seen once under ASan).
        self.assertTrue(wait_for(lambda: "stored again" in self.log(), timeout=10), self.log())


@unittest.skipIf(SKIP, SKIP)
class FleetTls(unittest.TestCase):
    """The fleet's own MQTT client over TLS: the broker's certificate verified against --ca-file and its
    address, a password login; a wrong password and a foreign CA are said in the log, and retried."""

    def test_tls_login_and_what_a_wrong_password_or_ca_says(self):
        with tempfile.TemporaryDirectory(prefix="gwft-") as d:
            ca, cert, key = mqtt_broker.make_certificates(d)
            broker = mqtt_broker.Broker(d, tls=(ca, cert, key), users={"fleet": "s3cret", "pub": "pw"})
            procs = []
            try:
                pw = os.path.join(d, "fleet.pw")
                with open(pw, "w") as f:
                    f.write("s3cret\n")
                os.chmod(pw, 0o600)
                db = os.path.join(d, "fleet.sqlite")
                log_path = os.path.join(d, "fleet.log")

                def fleet(*extra):
                    log = open(log_path, "w")
                    p = subprocess.Popen([GUIDEWAY, "fleet", "serve", "--broker", f"mqtts://127.0.0.1:{broker.port}",
                                          "--db", db, *extra], stdout=log, stderr=subprocess.STDOUT)
                    log.close()
                    procs.append(p)
                    return p

                def log():
                    with open(log_path) as f:
                        return f.read()
                p = fleet("--ca-file", ca, "--username", "fleet", "--password-file", pw)
                self.assertTrue(wait_for(lambda: "subscribed to guideway/#" in log(), timeout=20), log())
                subprocess.run(["mosquitto_pub", "-V", "mqttv5", "-h", "127.0.0.1", "-p", str(broker.port),
                                "--cafile", ca, "-u", "pub", "-P", "pw", "-q", "1", "-t", TOPIC,
                                "-m", payload(1, "tls")], check=True, capture_output=True, timeout=20)
                self.assertTrue(wait_for(lambda: stored_sessions(db, "tls") == ["tls-00001"], timeout=20), log())
                p.terminate()
                self.assertEqual(p.wait(timeout=20), 0)

                with open(pw, "w") as f:
                    f.write("wrong\n")
                p = fleet("--ca-file", ca, "--username", "fleet", "--password-file", pw)
                self.assertTrue(wait_for(lambda: "Not authorized" in log(), timeout=20), log())
                p.terminate()
                p.wait(timeout=20)
                os.mkdir(os.path.join(d, "other"))
                other_ca, _, _ = mqtt_broker.make_certificates(os.path.join(d, "other"))
                p = fleet("--ca-file", other_ca, "--username", "fleet", "--password-file", pw)
                self.assertTrue(wait_for(lambda: "certificate verify failed" in log(), timeout=20), log())
                self.assertIsNone(p.poll())  # still trying, with back-off
                p.terminate()
                p.wait(timeout=20)
                # A CA file that is not one: refused when it starts, not at the first connection.
                r = subprocess.run([GUIDEWAY, "fleet", "serve", "--broker", f"mqtts://127.0.0.1:{broker.port}",
                                    "--db", db, "--ca-file", pw], capture_output=True, text=True, timeout=20)
                self.assertEqual(r.returncode, 1)
                self.assertIn("no PEM certificate", r.stderr)
            finally:
                for p in procs:
                    if p.poll() is None:
                        p.kill()
                        p.wait()
                broker.stop()


if __name__ == "__main__":
    run_unittests()
