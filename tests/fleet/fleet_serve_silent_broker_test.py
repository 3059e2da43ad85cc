#!/usr/bin/python3
"""`guideway fleet serve` against a broker that accepts the TCP connection and then says nothing, or
only part of what it should (issue 46 items 8 and 13), played by a socket here:
- silent after the TCP accept (no CONNACK), plain and over TLS (no ServerHello: the TLS handshake waits):
  SIGTERM ends it within a second or two, not at the 10 s connect timeout;
- a CONNACK but no SUBACK: the log says "subscribed" only once the SUBACK arrives, never before.
Usage: fleet_serve_silent_broker_test.py BUILD_DIR"""
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")

CONNACK = bytes([0x20, 0x03, 0x00, 0x00, 0x00])  # MQTT 5: no session present, success, no properties
SUBACK = bytes([0x90, 0x04, 0x00, 0x01, 0x00, 0x01])  # packet id 1, no properties, granted QoS 1


class SilentBroker:
    """Accepts connections on a loopback port; `on_connect(conn)` decides what (if anything) is said."""

    def __init__(self, on_connect=None):
        self.server = socket.socket()
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(4)
        self.port = self.server.getsockname()[1]
        self.on_connect = on_connect
        self.conns = []
        self.accepted = threading.Event()
        threading.Thread(target=self.serve, daemon=True).start()

    def serve(self):
        while True:
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            self.conns.append(conn)
            self.accepted.set()
            if self.on_connect:
                threading.Thread(target=self.on_connect, args=(conn,), daemon=True).start()

    def close(self):
        self.server.close()
        for c in self.conns:
            c.close()


class FleetServeSilentBroker(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwfs-")
        self.addCleanup(self.tmp.cleanup)
        self.log_path = os.path.join(self.tmp.name, "fleet.log")

    def serve(self, url, *extra):
        log = open(self.log_path, "w")
        p = subprocess.Popen([GUIDEWAY, "fleet", "serve", "--broker", url, "--db",
                              os.path.join(self.tmp.name, "fleet.db"), *extra],
                             stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        log.close()

        def stop():
            if p.poll() is None:
                p.kill()
                p.wait()
        self.addCleanup(stop)
        return p

    def log(self):
        with open(self.log_path) as f:
            return f.read()

    def sigterm_ends_it_at_once(self, p, broker):
        self.assertTrue(broker.accepted.wait(10), "fleet serve never connected")
        time.sleep(1.0)  # well into the wait for CONNACK (or the TLS handshake)
        self.assertIsNone(p.poll(), self.log())
        sent = time.monotonic()
        p.send_signal(signal.SIGTERM)
        rc = p.wait(timeout=15)
        took = time.monotonic() - sent
        self.assertEqual(rc, 0, self.log())
        self.assertLess(took, 2.0, "SIGTERM took %.1f s to end fleet serve\n%s" % (took, self.log()))
        self.assertIn("stopped: stored 0 message(s)", self.log())

    def test_sigterm_while_waiting_for_connack(self):
        broker = SilentBroker()
        self.addCleanup(broker.close)
        self.sigterm_ends_it_at_once(self.serve("mqtt://127.0.0.1:%d" % broker.port), broker)

    def test_sigterm_in_the_tls_handshake(self):
        broker = SilentBroker()
        self.addCleanup(broker.close)
        self.sigterm_ends_it_at_once(self.serve("mqtts://127.0.0.1:%d" % broker.port), broker)

    def test_subscribed_is_said_when_the_suback_arrives(self):
        suback = threading.Event()

        def talk(conn):
            conn.recv(4096)  # CONNECT
            conn.sendall(CONNACK)
            conn.recv(4096)  # SUBSCRIBE
            suback.wait(30)
            conn.sendall(SUBACK)
            while True:
                try:
                    data = conn.recv(4096)
                except OSError:
                    return
                if not data:
                    return
                if data[:1] == b"\xc0":  # PINGREQ
                    conn.sendall(b"\xd0\x00")

        broker = SilentBroker(talk)
        self.addCleanup(broker.close)
        p = self.serve("mqtt://127.0.0.1:%d" % broker.port)
        deadline = time.monotonic() + 10
        while "connected to" not in self.log() and time.monotonic() < deadline:
            time.sleep(0.05)
        self.assertIn("connected to", self.log())
        time.sleep(1.0)
        self.assertNotIn("subscribed to", self.log(), "said subscribed before the broker's SUBACK")
        suback.set()
        deadline = time.monotonic() + 10
        while "subscribed to guideway/#" not in self.log() and time.monotonic() < deadline:
            time.sleep(0.05)
        self.assertIn("subscribed to guideway/# (the broker's SUBACK)", self.log())
        p.send_signal(signal.SIGTERM)
        self.assertEqual(p.wait(timeout=15), 0, self.log())


if __name__ == "__main__":
    unittest.main(verbosity=2)
