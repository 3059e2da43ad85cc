#!/usr/bin/env python3
"""A gauge amplifier served by Debian's python3-pymodbus, a Modbus stack written elsewhere than
Guideway (its datastore, framers and exception answers are pymodbus's own), with the register maps of
docs/protocols.md, for tests/drivers/micrometer_foreign_stack_test.cpp.

  pymodbus_amplifier.py --tcp PORT          Modbus TCP on 127.0.0.1:PORT (0: a free port)
  pymodbus_amplifier.py --rtu [--link PATH] Modbus RTU, 19200 8E1, on a pseudo-terminal pair (pymodbus on
                                            one, the client on the other, joined by a byte bridge);
                                            --link keeps a symlink to the client's end (a by-id name)

Prints "pymodbus VERSION", then "endpoint: tcp:127.0.0.1:PORT" or "endpoint: pty:PATH" (and "link:
PATH"). Unit 1, protocol (0-based) addresses:
  input 0-1     int32, high word first (ABCD): POLLED = -123456      input 2    status
  holding 10-11 int32, low word first (CDAB): 654321                 holding 12 status
  holding 20-21 float32, high word first: 12.5                       holding 22 status
  input 100-101 ring counter, high word first; input 200+3k: slot k = int32 ABCD + status
  holding 300-301 ring counter, low word first; holding 400+2k: slot k = int32 CDAB, no status
Ring sample number n (mod 2**32) holds ring_value(n), status 1 (out of range) when n % 1000 == 999;
it is filled up to the samples due at each request (sample n is due at n / rate after start).
Commands on stdin, each answered "ok" (or "error ..."): status S (the polled status registers),
exception N (the next N register requests answered with exception 02, illegal data address),
slow SECONDS N (the next N register requests answered SECONDS late), unplug SECONDS (RTU: the line is
gone at once, the link removed, then back on a new pseudo-terminal after SECONDS), quit.
"""
import argparse
import asyncio
import os
import select
import struct
import sys
import threading
import time
import tty

import logging

import pymodbus
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.server import StartAsyncSerialServer, StartAsyncTcpServer
from pymodbus.transaction import ModbusRtuFramer

POLLED = -123456
HOLDING_CDAB = 654321
FLOAT = 12.5


def ring_value(n):
    """The count of sample number n (a signed 32-bit value, deterministic so the test can check every sample)."""
    return (n * 7919) % 200001 - 100000


def words_abcd(v):
    u = v & 0xFFFFFFFF
    return [u >> 16, u & 0xFFFF]


def words_cdab(v):
    return list(reversed(words_abcd(v)))


class Amplifier:
    """The amplifier's state, shared by the server's event loop and the command thread."""

    def __init__(self, rate_hz, slots, counter_start):
        self.lock = threading.Lock()
        self.exceptions = 0
        self.slow_s = 0.0
        self.slow_n = 0
        self.rate_hz = rate_hz
        self.slots = slots
        self.counter_start = counter_start
        self.t0 = time.monotonic()
        self.filled = counter_start  # samples written into the rings so far
        self.inputs = None
        self.holdings = None

    def take_exception(self):
        with self.lock:
            if self.exceptions > 0:
                self.exceptions -= 1
                return True
            return False

    def delay(self):
        with self.lock:
            if self.slow_n <= 0:
                return 0.0
            self.slow_n -= 1
            return self.slow_s

    def fill(self):
        """Writes every sample due by now into both rings, then the counters (a slot before its count)."""
        due = self.counter_start + int((time.monotonic() - self.t0) * self.rate_hz)
        first = max(self.filled, due - self.slots)
        for n in range(first, due):
            k = n % (1 << 32)
            slot = k % self.slots
            status = 1 if k % 1000 == 999 else 0
            self.inputs.set_raw(200 + 3 * slot, words_abcd(ring_value(k)) + [status])
            self.holdings.set_raw(400 + 2 * slot, words_cdab(ring_value(k)))
        self.filled = due
        count = due % (1 << 32)
        self.inputs.set_raw(100, words_abcd(count))
        self.holdings.set_raw(300, words_cdab(count))


class Block(ModbusSequentialDataBlock):
    """pymodbus's sequential block, with the amplifier's faults and its ring filled at each read."""

    def __init__(self, amp, size):
        super().__init__(0, [0] * size)
        self.amp = amp

    def set_raw(self, address, values):
        super().setValues(address, values)

    def validate(self, address, count=1):
        if self.amp.take_exception():
            return False  # pymodbus answers exception 02
        return super().validate(address, count)

    def getValues(self, address, count=1):
        late = self.amp.delay()
        if late > 0:
            time.sleep(late)  # the whole server waits, as a slow amplifier does
        if self.amp.rate_hz > 0:
            self.amp.fill()
        return super().getValues(address, count)


class Line:
    """A pseudo-terminal pair joined by a byte bridge: pymodbus serves on `server_path`, clients open
    `client_path` (or the link to it). unplug() takes the client's end away for a while."""

    def __init__(self, link):
        self.link = link
        self.server_master, self.server_slave = os.openpty()
        tty.setraw(self.server_slave)
        self.server_path = os.ttyname(self.server_slave)
        self.lock = threading.Lock()
        self.client_master = None
        self.plug()
        threading.Thread(target=self.bridge, daemon=True).start()

    def plug(self):
        master, slave = os.openpty()
        tty.setraw(slave)
        path = os.ttyname(slave)
        os.close(slave)  # the client opens it; until then reads give EIO, which the bridge skips
        with self.lock:
            self.client_master = master
            self.client_path = path
        if self.link:
            tmp = self.link + ".new"
            if os.path.lexists(tmp):
                os.unlink(tmp)
            os.symlink(path, tmp)
            os.replace(tmp, self.link)

    def unplug(self, seconds):
        with self.lock:
            master, self.client_master = self.client_master, None
        if self.link and os.path.lexists(self.link):
            os.unlink(self.link)  # as udev removes /dev/serial/by-id/... with the device
        os.close(master)
        time.sleep(seconds)
        self.plug()

    def bridge(self):
        while True:
            with self.lock:
                client = self.client_master
            fds = [self.server_master] + ([client] if client is not None else [])
            ready, _, _ = select.select(fds, [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue  # the client's end is closed (EIO) or gone
                other = client if fd == self.server_master else self.server_master
                if other is None or not data:
                    continue
                try:
                    os.write(other, data)
                except OSError:
                    pass


def serve_commands(amp, line, loop, stop):
    for raw in sys.stdin:
        words = raw.split()
        if not words:
            continue
        try:
            if words[0] == "status":
                status = int(words[1], 0)
                loop.call_soon_threadsafe(lambda: [amp.inputs.set_raw(2, [status]), amp.holdings.set_raw(12, [status]),
                                                   amp.holdings.set_raw(22, [status])])
            elif words[0] == "exception":
                with amp.lock:
                    amp.exceptions += int(words[1])
            elif words[0] == "slow":
                with amp.lock:
                    amp.slow_s, amp.slow_n = float(words[1]), int(words[2])
            elif words[0] == "unplug" and line is not None:
                threading.Thread(target=line.unplug, args=(float(words[1]),), daemon=True).start()
            elif words[0] == "quit":
                break
            else:
                print("error unknown command", flush=True)
                continue
            print("ok", flush=True)
        except (IndexError, ValueError) as e:
            print(f"error {e}", flush=True)
    loop.call_soon_threadsafe(stop.set)


async def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tcp", type=int)
    ap.add_argument("--rtu", action="store_true")
    ap.add_argument("--link")
    ap.add_argument("--ring-rate-hz", type=float, default=1000.0)
    ap.add_argument("--ring-samples", type=int, default=512)
    ap.add_argument("--counter-start", type=int, default=0)
    a = ap.parse_args()
    logging.getLogger("pymodbus").setLevel(logging.DEBUG if os.environ.get("AMP_DEBUG") else logging.CRITICAL)  # a client going away is no error here
    amp = Amplifier(a.ring_rate_hz, a.ring_samples, a.counter_start)
    amp.inputs = Block(amp, 200 + 3 * a.ring_samples)
    amp.holdings = Block(amp, 400 + 2 * a.ring_samples)
    amp.inputs.set_raw(0, words_abcd(POLLED) + [0])
    amp.holdings.set_raw(10, words_cdab(HOLDING_CDAB) + [0])
    amp.holdings.set_raw(20, list(struct.unpack(">HH", struct.pack(">f", FLOAT))) + [0])
    if a.ring_rate_hz > 0:
        amp.fill()
    # zero_mode: protocol address a is register a of the block (pymodbus's default adds one).
    store = ModbusSlaveContext(ir=amp.inputs, hr=amp.holdings, zero_mode=True)
    context = ModbusServerContext(slaves={1: store}, single=False)
    print(f"pymodbus {pymodbus.__version__}", flush=True)
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    line = None
    if a.rtu:
        line = Line(a.link)
        # A pseudo-terminal carries bytes without parity bits, and this kernel refuses a second tcsetattr
        # with PARENB on one (pyserial reconfigures for asyncio): the server's end says "N".
        server = await StartAsyncSerialServer(context, framer=ModbusRtuFramer, port=line.server_path, baudrate=19200,
                                              parity="N", bytesize=8, stopbits=1, defer_start=True)
        await server.start()
        print(f"endpoint: pty:{line.client_path}", flush=True)
        if a.link:
            print(f"link: {a.link}", flush=True)
    else:
        server = await StartAsyncTcpServer(context, address=("127.0.0.1", a.tcp or 0), defer_start=True)
        task = asyncio.create_task(server.serve_forever())
        await server.serving
        port = server.server.sockets[0].getsockname()[1]
        print(f"endpoint: tcp:127.0.0.1:{port}", flush=True)
    threading.Thread(target=serve_commands, args=(amp, line, loop, stop), daemon=True).start()
    await stop.wait()
    if not a.rtu:
        task.cancel()
    await server.shutdown()


if __name__ == "__main__":
    asyncio.run(main())
