#!/usr/bin/env python3
"""Minimal guidewayd client (standard library only): connects to the daemon's Unix socket (or
tcp:HOST:PORT), subscribes to PARAMS and prints every identified parameter set as it is published.

    python3 docs/example_client.py                      # default socket
    python3 docs/example_client.py /run/guideway/guideway.sock
    python3 docs/example_client.py tcp:127.0.0.1:2947
"""
import json
import os
import socket
import sys


def default_socket():
    if os.environ.get("GUIDEWAY_SOCKET"):
        return os.environ["GUIDEWAY_SOCKET"]
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    user = os.path.join(runtime, "guideway", "guideway.sock") if runtime else f"/tmp/guideway-{os.getuid()}/guideway.sock"
    return user if os.path.exists(user) else "/run/guideway/guideway.sock"


def connect(address):
    if address.startswith("tcp:"):
        host, port = address[4:].rsplit(":", 1)
        return socket.create_connection((host, int(port)))
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.connect(address)
    return s


def main():
    address = sys.argv[1] if len(sys.argv) > 1 else default_socket()
    try:
        sock = connect(address)
    except (OSError, ValueError) as e:
        sys.exit(f"example_client: {address}: {e} (is guidewayd running? pass its socket or tcp:HOST:PORT)")
    with sock, sock.makefile("rw", encoding="utf-8", newline="\n") as stream:
        banner = json.loads(stream.readline())
        if banner.get("class") != "VERSION" or banner.get("proto_major") != 1:
            sys.exit(f"not a guidewayd protocol 1 socket: {banner}")
        print(f"connected to guidewayd {banner['release']} at {address}", flush=True)
        stream.write(json.dumps({"class": "watch", "classes": ["PARAMS", "EVENT"]}) + "\n")
        stream.flush()
        for line in stream:
            msg = json.loads(line)
            if msg["class"] == "PARAMS":
                print(f"\n{msg['session']} ({msg['kind']}, model {msg.get('model', '?')})")
                for group, items in msg.items():
                    if isinstance(items, dict) and items and all(isinstance(v, dict) and "value" in v for v in items.values()):
                        for name, v in items.items():
                            u = f" +/- {v['u']:.4g}" if "u" in v else ""
                            print(f"  {group}.{name} = {v['value']:.6g}{u}")
                sys.stdout.flush()
            elif msg["class"] == "EVENT":
                print(f"event: {msg.get('device', '')} {msg.get('event')} {msg.get('reason', '')}", flush=True)
            elif msg["class"] == "ERROR":
                print(f"error: {msg['message']}", file=sys.stderr)


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        pass
    except OSError as e:
        sys.exit(f"example_client: {e}")
