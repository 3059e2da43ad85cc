#!/usr/bin/python3
"""Records the golden files of tests/sessions/replay_golden_test.py from a live daemon: starts guidewayd on its
embedded default (four emulated instruments), runs one session of each KIND through the client, and
stores its raw recording as GOLDEN_DIR/KIND.csv, the PARAMS it published as KIND.params.json and the
EXPLAIN as KIND.explain.json.

    tests/sessions/record_golden.py BUILD_DIR GOLDEN_DIR [KIND ...]   (default kinds: dbb straightness runout profile)
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

IGNORED = {"replayed_from", "recording", "derived"}


def main():
    build, golden = sys.argv[1], sys.argv[2]
    kinds = sys.argv[3:] or ["dbb", "straightness", "runout", "profile"]
    guidewayd = os.path.join(build, "daemon", "guidewayd")
    guideway = os.path.join(build, "cli", "guideway")
    os.makedirs(golden, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="gw-golden-") as tmp:
        sock = os.path.join(tmp, "g.sock")
        env = {**os.environ, "XDG_STATE_HOME": os.path.join(tmp, "state")}
        env.pop("NOTIFY_SOCKET", None)
        with open(os.path.join(tmp, "log"), "w+") as log:
            daemon = subprocess.Popen([guidewayd, "--socket", sock], env=env, stdout=log, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL)
            try:
                deadline = time.monotonic() + 30
                while not os.path.exists(sock):
                    if daemon.poll() is not None or time.monotonic() > deadline:
                        log.seek(0)
                        sys.exit("guidewayd did not start:\n" + log.read())
                    time.sleep(0.05)
                time.sleep(3)  # the instruments come up
                for kind in kinds:
                    out = subprocess.run([guideway, "--socket", sock, "start", kind, "--wait", "--json", "--timeout", "240"],
                                         capture_output=True, text=True, timeout=300)
                    if out.returncode != 0:
                        sys.exit(f"{kind}: {out.stderr}{out.stdout}")
                    params = json.loads(out.stdout.strip().splitlines()[-1])
                    shutil.copyfile(params["recording"], os.path.join(golden, kind + ".csv"))
                    with open(os.path.join(golden, kind + ".params.json"), "w") as f:
                        json.dump({k: v for k, v in params.items() if k not in IGNORED}, f, indent=1, sort_keys=True)
                        f.write("\n")
                    # The EXPLAIN follows the PARAMS (computed on the daemon's worker thread).
                    deadline = time.monotonic() + 120
                    while True:
                        ex = subprocess.run([guideway, "--socket", sock, "explain", "--latest", "--kind", kind, "--json"],
                                            capture_output=True, text=True, timeout=60)
                        explain = json.loads(ex.stdout.splitlines()[-1]) if ex.stdout.strip() else {}
                        if explain.get("session") == params["session"]:
                            break
                        if time.monotonic() > deadline:
                            sys.exit(f"{kind}: no EXPLAIN for {params['session']}: {ex.stderr}{ex.stdout}")
                        time.sleep(0.3)
                    with open(os.path.join(golden, kind + ".explain.json"), "w") as f:
                        json.dump({k: v for k, v in explain.items() if k not in IGNORED}, f, indent=1, sort_keys=True)
                        f.write("\n")
                    print(f"recorded {kind}: {params['samples']} samples")
            finally:
                daemon.send_signal(signal.SIGTERM)
                daemon.wait(timeout=30)


if __name__ == "__main__":
    main()
