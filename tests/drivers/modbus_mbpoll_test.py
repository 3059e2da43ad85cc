#!/usr/bin/python3
"""Debian's mbpoll, a Modbus master written elsewhere, against Guideway's gauge-amplifier emulator
(`guideway-emulate micrometer`) over Modbus TCP and Modbus RTU (a pseudo-terminal): the register map of
docs/protocols.md read with mbpoll's own decoding (its 1-based references and 0-based -0 addressing,
int32 high word first with -B), the sample ring's counter advancing at its rate across the 32-bit
wrap, Report Server ID (FC 17) on RTU, the emulator's exception answers and addresses outside the map.
Skipped, saying why, where mbpoll is missing.
Usage: modbus_mbpoll_test.py BUILD_DIR"""
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import unittest

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
EMULATE = os.path.join(BUILD, "simulators", "emulators", "guideway-emulate")
MBPOLL = shutil.which("mbpoll")
RING_RATE_HZ = 1000
COUNTER_START = 2**32 - 300  # the counter wraps 0.3 s after the start


class Emulator:
    def __init__(self, *args):
        self.p = subprocess.Popen([EMULATE, "micrometer", "--rpm", "0.001", "--ring-rate-hz", str(RING_RATE_HZ),
                                   "--ring-counter-start", str(COUNTER_START), *args],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.p.stdout.readline().strip()
        assert line.startswith("endpoint: "), line
        self.kind, self.address = line[len("endpoint: "):].split(":", 1)

    def command(self, line):
        """A fault command on stdin; the emulator answers on stderr."""
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()
        return self.p.stderr.readline().strip()

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)
            self.p.wait(timeout=10)
        for f in (self.p.stdin, self.p.stdout, self.p.stderr):
            f.close()


def mbpoll(emu, *args):
    """One poll (-1) with mbpoll; returns (exit code, {reference: value}, output)."""
    if emu.kind == "tcp":
        host, port = emu.address.rsplit(":", 1)
        where = ["-m", "tcp", "-p", port, host]
    else:
        where = ["-m", "rtu", "-b", "19200", "-P", "even", emu.address]
    out = subprocess.run([MBPOLL, "-a", "1", "-1", "-o", "1", *args, *where], capture_output=True, text=True,
                         timeout=20)
    values = {int(m.group(1)): int(m.group(2)) for m in re.finditer(r"^\[(\d+)\]:\s+(-?\d+)", out.stdout, re.M)}
    return out.returncode, values, out.stdout + out.stderr


@unittest.skipUnless(MBPOLL, "mbpoll is not installed (scripts/setup.sh installs it)")
class MbpollAgainstTheEmulator(unittest.TestCase):
    def check_map(self, emu):
        # Input registers 0-1 (int32, high word first) and 2 (status), as 16-bit words: mbpoll's
        # references are 1-based (-r 1 is protocol address 0; a manual's 30001).
        rc, words, out = mbpoll(emu, "-t", "3", "-r", "1", "-c", "3")
        self.assertEqual(rc, 0, out)
        self.assertEqual(sorted(words), [1, 2, 3], out)
        composed = ((words[1] & 0xFFFF) << 16 | (words[2] & 0xFFFF))
        composed = composed - 2**32 if composed >= 2**31 else composed
        self.assertEqual(words[3], 0, "status: in range, probe present")
        self.assertLess(abs(composed), 100000, "a run-out of micrometres, in 10 nm counts")
        # The same as one int32 with mbpoll's own decoding, high word first (-B): Guideway's word_order = "big".
        rc, as_int, out = mbpoll(emu, "-t", "3:int", "-B", "-r", "1", "-c", "1")
        self.assertEqual(rc, 0, out)
        self.assertLessEqual(abs(as_int[1] - composed), 2, out)  # the spindle barely turns (--rpm 0.001)
        # -0: PDU (0-based) addressing, the addresses of docs/protocols.md.
        rc, zero_based, out = mbpoll(emu, "-0", "-t", "3:int", "-B", "-r", "0", "-c", "1")
        self.assertEqual(rc, 0, out)
        self.assertLessEqual(abs(zero_based[0] - composed), 2, out)
        # The ring's counter (input 100-101, high word first) advances at the sampling rate, across 2**32.
        t0 = time.monotonic()
        rc, c0, out = mbpoll(emu, "-0", "-t", "3:int", "-B", "-r", "100", "-c", "1")
        self.assertEqual(rc, 0, out)
        time.sleep(0.5)
        rc, c1, out = mbpoll(emu, "-0", "-t", "3:int", "-B", "-r", "100", "-c", "1")
        elapsed = time.monotonic() - t0
        self.assertEqual(rc, 0, out)
        advanced = (c1[100] - c0[100]) % 2**32  # mbpoll prints it signed
        self.assertGreater(advanced, 0.4 * RING_RATE_HZ)
        self.assertLess(advanced, (elapsed + 0.5) * RING_RATE_HZ)
        # A slot of the ring: int32 + status, the status of a sample in range is 0.
        rc, slot, out = mbpoll(emu, "-0", "-t", "3", "-r", "200", "-c", "3")
        self.assertEqual(rc, 0, out)
        self.assertEqual(slot[202], 0, out)

    def check_exceptions(self, emu):
        # Outside the map: libmodbus's own exception answer, which mbpoll names.
        rc, _, out = mbpoll(emu, "-0", "-t", "3", "-r", "60000", "-c", "2")
        self.assertNotEqual(rc, 0, out)
        self.assertIn("Illegal data address", out)
        # The emulator's injected exception (06, server busy), then a normal answer again.
        self.assertTrue(emu.command("fault exception 1").startswith("ok"))
        rc, _, out = mbpoll(emu, "-0", "-t", "3", "-r", "0", "-c", "3")
        self.assertNotEqual(rc, 0, out)
        self.assertIn("busy", out.lower())
        rc, _, out = mbpoll(emu, "-0", "-t", "3", "-r", "0", "-c", "3")
        self.assertEqual(rc, 0, out)

    def test_tcp(self):
        emu = Emulator("--tcp", "127.0.0.1:0")
        try:
            self.check_map(emu)
            self.check_exceptions(emu)
        finally:
            emu.stop()

    def test_rtu(self):
        emu = Emulator("--rtu")
        try:
            self.assertEqual(emu.kind, "pty")
            self.check_map(emu)
            self.check_exceptions(emu)
            # Report Server ID (FC 17), which the driver sends to bring an RTU line back in step.
            rc, _, out = mbpoll(emu, "-u")
            self.assertEqual(rc, 0, out)
        finally:
            emu.stop()


if __name__ == "__main__":
    unittest.main()
