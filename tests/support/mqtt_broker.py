"""A real MQTT broker for the tests: Debian's mosquitto on a free loopback port, plain or TLS with
certificates made here by openssl, anonymous or with a password file; and mosquitto_sub as an
independent subscriber. `missing()` says why the tests must skip (no mosquitto installed)."""
import getpass
import os
import shutil
import signal
import socket
import subprocess
import time

from process_support import wait_for


def missing():
    for tool in ("mosquitto", "mosquitto_sub", "mosquitto_passwd", "openssl"):
        if shutil.which(tool) is None and not os.path.exists("/usr/sbin/" + tool):
            return f"{tool} is not installed (scripts/setup.sh installs mosquitto, mosquitto-clients and openssl)"
    return None


def mosquitto_binary():
    return shutil.which("mosquitto") or "/usr/sbin/mosquitto"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def make_certificates(directory):
    """A CA, and a server certificate it signed for 127.0.0.1; returns (ca, cert, key) paths."""
    ca_key, ca, key, csr, cert = (os.path.join(directory, n) for n in ("ca.key", "ca.pem", "server.key", "server.csr", "server.pem"))
    quiet = {"check": True, "capture_output": True}
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", ca_key, "-out", ca,
                    "-days", "2", "-subj", "/CN=guideway test CA"], **quiet)
    subprocess.run(["openssl", "req", "-newkey", "rsa:2048", "-nodes", "-keyout", key, "-out", csr,
                    "-subj", "/CN=127.0.0.1"], **quiet)
    ext = os.path.join(directory, "san.ext")
    with open(ext, "w") as f:
        f.write("subjectAltName=IP:127.0.0.1\n")
    subprocess.run(["openssl", "x509", "-req", "-in", csr, "-CA", ca, "-CAkey", ca_key, "-CAcreateserial",
                    "-out", cert, "-days", "2", "-extfile", ext], **quiet)
    os.chmod(key, 0o644)  # mosquitto may drop privileges; the test owns the directory
    return ca, cert, key


class Broker:
    """mosquitto on 127.0.0.1:port. tls=(ca, cert, key); users={name: password} turns anonymous off;
    acl: the text of an acl_file;
    persistence keeps sessions and retained messages across kill()/start() (saved every second);
    extra_conf: more lines for mosquitto.conf (max_queued_messages 0, ...)."""

    def __init__(self, directory, tls=None, users=None, persistence=False, acl=None, extra_conf=()):
        self.dir = directory
        self.port = free_port()
        self.conf = os.path.join(directory, "mosquitto.conf")
        self.log_path = os.path.join(directory, "mosquitto.log")
        # Run as root (CI), mosquitto would switch to the `mosquitto` user, which cannot read this directory.
        lines = [f"user {getpass.getuser()}", f"listener {self.port} 127.0.0.1"]
        if tls:
            ca, cert, key = tls
            lines += [f"cafile {ca}", f"certfile {cert}", f"keyfile {key}"]
        if users:
            pw = os.path.join(directory, "passwords")
            open(pw, "w").close()
            for name, password in users.items():
                subprocess.run(["mosquitto_passwd", "-b", pw, name, password], check=True, capture_output=True)
            lines += ["allow_anonymous false", f"password_file {pw}"]
        else:
            lines.append("allow_anonymous true")
        if acl:
            path = os.path.join(directory, "acl")
            with open(path, "w") as f:
                f.write(acl)
            lines.append(f"acl_file {path}")
        if persistence:
            lines += ["persistence true", f"persistence_location {directory}/", "autosave_interval 1"]
        lines += list(extra_conf)
        with open(self.conf, "w") as f:
            f.write("\n".join(lines) + "\n")
        self.proc = None
        self.start()

    def start(self):
        self.log = open(self.log_path, "a")
        self.proc = subprocess.Popen([mosquitto_binary(), "-c", self.conf], stdout=self.log, stderr=subprocess.STDOUT)

        def listening():
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return True
            except OSError:
                return False
        if not wait_for(listening, timeout=10):
            raise RuntimeError("mosquitto did not start:\n" + open(self.log_path).read())

    def wait_saved(self, client_id, timeout=15):
        """With persistence: waits until `client_id` has connected and the broker has saved its database
        since (so that a SIGKILL keeps that client's session)."""
        def connected_at():
            with open(self.log_path) as f:
                return "as " + client_id + " " in f.read() and time.time()
        since = wait_for(connected_at, timeout=timeout)
        db = os.path.join(self.dir, "mosquitto.db")
        if not since or not wait_for(lambda: os.path.exists(db) and os.path.getmtime(db) > since, timeout=timeout):
            raise RuntimeError(f"mosquitto did not save {client_id}'s session:\n" + open(self.log_path).read())

    def kill(self, sig=signal.SIGKILL):
        self.proc.send_signal(sig)
        self.proc.wait(timeout=10)
        self.log.close()

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.kill(signal.SIGTERM)


class Subscriber:
    """mosquitto_sub on `topic`, MQTT v5, QoS 1, one "TOPIC PAYLOAD" line per message into a file.
    With client_id it keeps its session on the broker (it is queued for while away)."""

    def __init__(self, broker, topic, path, client_id=None, extra=()):
        args = ["mosquitto_sub", "-V", "mqttv5", "-h", "127.0.0.1", "-p", str(broker.port), "-t", topic, "-q", "1",
                "-F", "%t %p", *extra]
        if client_id:
            args += ["-c", "-i", client_id, "-x", "3600"]
        self.path = path
        self.out = open(path, "w")
        self.proc = subprocess.Popen(args, stdout=self.out, stderr=subprocess.STDOUT)

    def messages(self):
        with open(self.path) as f:
            return [tuple(line.rstrip("\n").split(" ", 1)) for line in f if " " in line]

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=10)
        self.out.close()


def retained(broker, topic, extra=()):
    """The retained message on `topic` (payload text), or None."""
    out = subprocess.run(["mosquitto_sub", "-V", "mqttv5", "-h", "127.0.0.1", "-p", str(broker.port), "-t", topic,
                          "--retained-only", "-C", "1", "-W", "3", *extra], capture_output=True, text=True)
    return out.stdout.strip() or None
