#!/usr/bin/env python3
"""Three CANopen encoder nodes written from the CiA 301/406 facts alone, independently of Guideway's
code and emulator, on a Unix SOCK_SEQPACKET socket carrying struct can_frame records (the dbb-can
driver's `unix:` bus). For tests/drivers/canopen_daemon_test.py.

  cia301_nodes.py SOCKET_PATH [--nodes 1 2 3] [--serials 4001 4002 4003]

What a node does (CiA 301): at power-on it sends its boot-up message (COB-ID 0x700+id, one byte 00)
and is pre-operational; NMT commands on COB-ID 0x000 (two bytes: command, node-ID or 0 for all):
0x01 start -> operational, 0x02 stop -> stopped, 0x80 -> pre-operational, 0x81/0x82 reset -> boot-up
again; in operational state it answers each SYNC (COB-ID 0x080) with TPDO1 (0x180+id: its position,
object 0x6004, 4 bytes little-endian) when 0x1800:2 is 1..240 (every n-th SYNC); it sends its heartbeat
(0x700+id, its state: 05 operational, 7F pre-operational, 04 stopped) every 0x1017 ms; its SDO server
(requests on 0x600+id, answers on 0x580+id, 8 bytes: command, index LE, sub-index, data) answers
expedited uploads (0x40 -> 0x43/0x47/0x4B/0x4F by size) and downloads (0x23/0x27/0x2B/0x2F -> 0x60)
and aborts (0x80 + code) otherwise: 0x06020000 no object, 0x06090011 no sub-index, 0x06010002 read
only, 0x06070010 wrong length, 0x05040001 unknown command.
As a bus does for a socket that asks (SocketCAN's CAN_RAW_RECV_OWN_MSGS), a SYNC is given back to
the one that wrote it, before the nodes' answers. Prints "listening: PATH". Commands on stdin: reboot NODE (power off 0.2 s, then boot), quit.
"""
import math
import os
import select
import socket
import struct
import sys
import threading
import time

FRAME = struct.Struct("<IB3x8s")  # struct can_frame: can_id, can_dlc, 3 pad bytes, data[8]


class Node:
    def __init__(self, node_id, serial, resolution_nm):
        self.id = node_id
        self.serial = serial
        self.resolution_nm = resolution_nm
        self.powered_at = None
        self.power_on()

    def power_on(self):
        self.state = 0x7F  # pre-operational, after the boot-up message the caller sends
        self.tx_type = 254  # factory default of many encoders: event-driven; the master must set 1
        self.heartbeat_ms = 0
        self.sync_count = 0
        self.next_heartbeat = 0.0
        self.off_until = 0.0

    def objects(self):
        """(index, sub) -> (value, size, writable)"""
        return {(0x1000, 0): (406, 4, False), (0x1001, 0): (0, 1, False), (0x1017, 0): (self.heartbeat_ms, 2, True),
                (0x1018, 0): (4, 1, False), (0x1018, 1): (0x00000123, 4, False), (0x1018, 2): (0x0406A001, 4, False),
                (0x1018, 3): (0x00030001, 4, False), (0x1018, 4): (self.serial, 4, False),
                (0x1800, 0): (5, 1, False), (0x1800, 1): (0x180 + self.id, 4, False),
                (0x1800, 2): (self.tx_type, 1, True), (0x6004, 0): (self.count(), 4, False),
                (0x6005, 0): (1, 1, False), (0x6005, 1): (self.resolution_nm, 4, False)}

    def count(self):
        # An axis moving sinusoidally, 10 mm amplitude, in counts of the node's resolution.
        position_nm = 10e6 * math.sin(time.monotonic() * (0.5 + self.id))
        return int(round(position_nm / self.resolution_nm)) & 0xFFFFFFFF

    def sdo(self, data):
        """The answer (8 bytes) to an SDO request, or None."""
        cs, index, sub, value = data[0], data[1] | data[2] << 8, data[3], struct.unpack_from("<I", data, 4)[0]
        objs = self.objects()

        def abort(code):
            return bytes([0x80, data[1], data[2], sub]) + struct.pack("<I", code)
        if cs >> 5 == 2:  # initiate upload
            if (index, sub) not in objs:
                return abort(0x06090011 if any(i == index for i, _ in objs) else 0x06020000)
            v, size, _ = objs[(index, sub)]
            return bytes([0x43 | (4 - size) << 2, data[1], data[2], sub]) + struct.pack("<I", v & 0xFFFFFFFF)
        if cs >> 5 == 1 and cs & 0x02:  # initiate download, expedited
            if (index, sub) not in objs:
                return abort(0x06090011 if any(i == index for i, _ in objs) else 0x06020000)
            _, size, writable = objs[(index, sub)]
            if not writable:
                return abort(0x06010002)
            if cs & 0x01 and 4 - (cs >> 2 & 0x03) != size:
                return abort(0x06070010)
            value &= (1 << 8 * size) - 1
            if (index, sub) == (0x1800, 2):
                self.tx_type, self.sync_count = value, 0
            elif (index, sub) == (0x1017, 0):
                self.heartbeat_ms, self.next_heartbeat = value, time.monotonic()
            return bytes([0x60, data[1], data[2], sub, 0, 0, 0, 0])
        return abort(0x05040001)


class Bus:
    def __init__(self, path, node_ids, serials):
        self.nodes = [Node(n, s, 100) for n, s in zip(node_ids, serials)]
        if os.path.exists(path):
            os.unlink(path)
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.listener.bind(path)
        self.listener.listen(1)
        self.conn = None
        self.lock = threading.Lock()

    def send(self, can_id, data):
        if self.conn is None:
            return
        try:
            self.conn.send(FRAME.pack(can_id, len(data), bytes(data).ljust(8, b"\0")))
        except OSError:
            self.conn = None

    def boot(self, node):
        node.power_on()
        self.send(0x700 + node.id, [0x00])

    def reboot(self, node_id):
        with self.lock:
            for node in self.nodes:
                if node.id == node_id:
                    node.off_until = time.monotonic() + 0.2

    def receive(self, frame):
        can_id, dlc, data = FRAME.unpack(frame)
        data = data[:dlc]
        if can_id == 0x080:
            self.send(can_id, data)  # the bus gives a SYNC back to its writer, before the answers
        for node in self.nodes:
            if node.off_until:
                continue
            if can_id == 0x000 and dlc == 2 and data[1] in (0, node.id):
                if data[0] == 0x01:
                    node.state = 0x05
                elif data[0] == 0x02:
                    node.state = 0x04
                elif data[0] == 0x80:
                    node.state = 0x7F
                elif data[0] in (0x81, 0x82):
                    self.boot(node)
            elif can_id == 0x600 + node.id and dlc == 8 and node.state != 0x04:
                answer = node.sdo(data)
                if answer:
                    self.send(0x580 + node.id, answer)
            elif can_id == 0x080 and node.state == 0x05 and 1 <= node.tx_type <= 240:
                node.sync_count += 1
                if node.sync_count >= node.tx_type:
                    node.sync_count = 0
                    self.send(0x180 + node.id, struct.pack("<I", node.count()))

    def tick(self):
        now = time.monotonic()
        for node in self.nodes:
            if node.off_until:
                if now >= node.off_until:
                    self.boot(node)
                continue
            if node.heartbeat_ms and now >= node.next_heartbeat:
                self.send(0x700 + node.id, [node.state])
                node.next_heartbeat = max(node.next_heartbeat + node.heartbeat_ms / 1000, now)

    def run(self):
        for node in self.nodes:  # powered on before anyone listens: nobody hears these boot-ups
            self.boot(node)
        while True:
            fds = [self.listener] + ([self.conn] if self.conn else [])
            ready, _, _ = select.select(fds, [], [], 0.005)
            with self.lock:
                if self.listener in ready:
                    self.conn, _ = self.listener.accept()
                if self.conn is not None and self.conn in ready:
                    try:
                        frame = self.conn.recv(64)
                    except OSError:
                        frame = b""
                    if not frame:
                        self.conn = None
                    elif len(frame) == FRAME.size:
                        self.receive(frame)
                self.tick()


def main():
    args = sys.argv[1:]
    path = args[0]
    nodes, serials = [1, 2, 3], [4001, 4002, 4003]
    if "--nodes" in args:
        i = args.index("--nodes")
        nodes = [int(x) for x in args[i + 1:i + 4]]
    if "--serials" in args:
        i = args.index("--serials")
        serials = [int(x) for x in args[i + 1:i + 4]]
    bus = Bus(path, nodes, serials)
    threading.Thread(target=bus.run, daemon=True).start()
    print(f"listening: {path}", flush=True)
    for line in sys.stdin:
        words = line.split()
        if words[:1] == ["reboot"]:
            bus.reboot(int(words[1]))
            print("ok", flush=True)
        elif words[:1] == ["quit"]:
            break


if __name__ == "__main__":
    main()
