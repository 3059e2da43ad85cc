#!/usr/bin/python3
"""`guideway explain --model traverse` on real DABAM slope profiles (tests/data/dabam), read as they are.

usage: dabam_explain_cli_test.py GUIDEWAY DABAM_DIR

Each entry is one forward pass without times, read with the deflectometer's range by default: a flat, a
flat tilted by 1,000" (031), a curved mirror spanning 1,664" (020), positions that jitter by 0.34 % of a
step (901). On a real profile alone EXPLAIN must find no effect (what the polynomial base leaves of the
real surface may be reported as unexplained, with its place); every candidate is listed in `considered`;
the notes say one pass, no times, and the places are told in readings, not seconds. The TA80's range refuses the curved mirror, naming its readings.
(Small entries only: the suite runs under ASan.)
"""
import json
import os
import subprocess
import sys

GUIDEWAY, DABAM = sys.argv[1], sys.argv[2]
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def explain(*args):
    p = subprocess.run([GUIDEWAY, "explain", "--model", "traverse", "--quiet", *args], capture_output=True,
                       text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


for name in ("dabam-009", "dabam-031", "dabam-020", "dabam-901"):
    rc, out, err = explain("--json", os.path.join(DABAM, name + ".dat"))
    if rc != 0:
        check(False, "%s explained (%s)" % (name, err.strip()))
        continue
    j = json.loads(out)
    considered = {c["effect"] for c in j["considered"]}
    notes = " | ".join(j["notes"])
    check(j["model"] == "traverse" and j["findings"] == [] and "pitch_wave" in considered
          and "passes one way only" in notes and "no pass back or repeat with times" in notes,
          "%s: %d readings as one pass, no finding on the real profile alone (considered: %s; unexplained: %s)"
          % (name, j["n"], sorted(considered), j["unexplained"]))

# Without times the places are told in readings, never in seconds (issue 41: "reading N" used to read "N s").
rc, out, err = explain(os.path.join(DABAM, "dabam-031.dat"))
rc_j, out_j, _ = explain("--json", os.path.join(DABAM, "dabam-031.dat"))
locations = [l for m in json.loads(out_j)["remaining"] for l in m.get("locations", [])] if rc_j == 0 else []
check(rc == 0 and " s from its start" not in out and "readings 0..9 of it (no times recorded)" in out
      and locations and all("readings_from_run_start" in l and "t_from_run_start_s" not in l for l in locations),
      "dabam-031 (no times): its places in readings (%s)" % [l.get("readings_from_run_start") for l in locations])

rc, out, err = explain("--instrument", "autocollimator", os.path.join(DABAM, "dabam-020.dat"))
check(rc == 1 and "slope spans 1664.39\"" in err and "more than the autocollimator's range +-600\"" in err,
      "dabam-020 with the TA80: refused, its span named (%s)" % err.strip())
rc, out, err = explain("--instrument", "autocollimator", "--range-arcsec", "1000", os.path.join(DABAM, "dabam-020.dat"))
check(rc == 0, "dabam-020 with the TA80 and --range-arcsec 1000: explained")

if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
