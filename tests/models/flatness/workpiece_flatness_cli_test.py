#!/usr/bin/python3
"""`guideway-emulate workpiece` + `guideway identify flatness` end to end, with numpy/PyWavelets as the oracle.

Usage: workpiece_flatness_cli_test.py GUIDEWAY GUIDEWAY_EMULATE MACHINE_TOML

- The Mu experiment files from the emulated lathe (2 and 8 mm/min, 110 rpm, 600 mm).
- Eq. 18's low-frequency part recomputed with pywt (wavedec/waverec of the approximation only),
  Eqs. 19/20 with numpy.corrcoef, the squareness slope and its fit uncertainty with numpy.linalg.lstsq:
  all must agree with the JSON.
- Bad files stop with "guideway: FILE:LINE: message" and exit status 1.
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pywt

GUIDEWAY, EMULATE, MACHINE = sys.argv[1], sys.argv[2], sys.argv[3]
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def read_profile(path):
    xs, zs, header = [], [], False
    for line in open(path):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if not header:
            header = True
            continue
        x, z = line.split(",")
        xs.append(float(x))
        zs.append(float(z))
    return np.array(xs), np.array(zs)


with tempfile.TemporaryDirectory() as d:
    p = subprocess.run([EMULATE, "workpiece", "--machine", MACHINE, "--out-dir", d, "--profile-step-mm", "0.1"],
                       capture_output=True, text=True, timeout=60)
    check(p.returncode == 0, "guideway-emulate workpiece runs: " + p.stderr.strip())
    files = p.stdout.split()
    check(len(files) == 4, "four files written: %s" % files)
    prof = [os.path.join(d, "profile_2mm_per_min.csv"), os.path.join(d, "profile_8mm_per_min.csv")]
    args = [GUIDEWAY, "identify", "flatness", "--profile", prof[0], "--profile", prof[1], "--straightness",
            os.path.join(d, "straightness.csv"), "--runout", os.path.join(d, "runout.csv"), "--angle-u-arcsec", "0.1"]
    p = subprocess.run(args + ["--json"], capture_output=True, text=True, timeout=60)
    check(p.returncode == 0, "identify flatness --json runs: " + p.stderr.strip())
    r = json.loads(p.stdout)
    b = np.array(r["straightness"]["b_mm"])
    x0 = r["straightness"]["x_start_mm"]
    for path, pr in zip(prof, r["profiles"]):
        x, z = read_profile(path)
        y2 = 1e3 * np.polyval(b[::-1], x - x0)  # um
        y1 = x - x[0]
        coeffs = pywt.wavedec(z, "db1", mode="symmetric", level=5)
        x1 = pywt.waverec([coeffs[0]] + [np.zeros_like(c) for c in coeffs[1:]], "db1", mode="symmetric")[: len(z)]
        g = {"squareness": (np.corrcoef(z, y1)[0, 1], np.corrcoef(x1, y1)[0, 1]),
             "straightness": (np.corrcoef(z, y2)[0, 1], np.corrcoef(x1, y2)[0, 1])}
        for name, (before, after) in g.items():
            c = pr["correlation"][name]
            check(abs(c["gamma_before"] - before) < 1e-9 and abs(c["gamma_after"] - after) < 1e-9,
                  "%s %s: gamma before %.6f after %.6f (numpy %.6f %.6f)" %
                  (os.path.basename(path), name, c["gamma_before"], c["gamma_after"], before, after))
        J = np.column_stack([np.ones_like(x), (x - x[0]) * 1e-3])
        sol, res, *_ = np.linalg.lstsq(J, (z - y2) * 1e-6, rcond=None)
        resid = (z - y2) * 1e-6 - J @ sol
        s2 = resid @ resid / (len(x) - 2)
        u = np.sqrt(s2 * np.linalg.inv(J.T @ J)[1, 1])
        rho = min(max((resid[:-1] @ resid[1:]) / (resid @ resid), 0.0), 0.99)
        u *= np.sqrt((1 + rho) / (1 - rho))
        check(abs(pr["squareness_urad"] - sol[1] * 1e6) < 1e-9 * max(1.0, abs(sol[1] * 1e6)),
              "%s squareness %.6f urad (numpy %.6f)" % (os.path.basename(path), pr["squareness_urad"], sol[1] * 1e6))
        check(abs(pr["u_fit_urad"] - u * 1e6) < 1e-6 * u * 1e6,
              "%s u_fit %.6f urad (numpy %.6f)" % (os.path.basename(path), pr["u_fit_urad"], u * 1e6))
        check(pr["dominant"] == "squareness" and pr["correlation"]["squareness"]["gamma_after"] > 0.95 and
              pr["correlation"]["squareness"]["gamma_before"] < 0.9,
              "%s: squareness dominant, gamma after > 0.95, before < 0.9" % os.path.basename(path))
    check(abs(r["squareness_urad"] - 2.8) < 3 * r["u_squareness_urad"],
          "squareness %.4f +- %.4f urad (machine: 2.8)" % (r["squareness_urad"], r["u_squareness_urad"]))
    rc = r["runout_check"]
    check(abs(rc["difference_urad"]) < 3 * rc["u_difference_urad"] and abs(rc["eq21_squareness_urad"] - 2.8) < 0.02,
          "Eq. 21 %.4f urad; profile - Eq. 21 = %.4f +- %.4f urad (within 3u; the 2u flag says %s)"
          % (rc["eq21_squareness_urad"], rc["difference_urad"], rc["u_difference_urad"], rc["consistent"]))
    p = subprocess.run(args, capture_output=True, text=True, timeout=60)
    check(p.returncode == 0 and "dominant error: squareness" in p.stdout, "text output names the dominant error")

    # Bad input: a non-numeric cell in a profile, a missing column in the traverse.
    lines = open(prof[0]).read().splitlines()
    data_start = next(i for i, l in enumerate(lines) if l.startswith("x_mm")) + 1
    lines[data_start + 9] = lines[data_start + 9].split(",")[0] + ",oops"
    bad = os.path.join(d, "bad.csv")
    open(bad, "w").write("\n".join(lines) + "\n")
    p = subprocess.run([GUIDEWAY, "identify", "flatness", "--profile", bad, "--straightness",
                        os.path.join(d, "straightness.csv")], capture_output=True, text=True, timeout=60)
    check(p.returncode == 1 and p.stderr.startswith("guideway: %s:%d:" % (bad, data_start + 10)),
          "non-numeric cell: " + p.stderr.strip())
    tr = os.path.join(d, "tr.csv")
    open(tr, "w").write("# step_mm = 10\nx_mm,yaw_arcsec\n0,1\n10,2\n")
    p = subprocess.run([GUIDEWAY, "identify", "flatness", "--profile", prof[0], "--straightness", tr],
                       capture_output=True, text=True, timeout=60)
    check(p.returncode == 1 and p.stderr.startswith("guideway: %s:2:" % tr) and "pitch_arcsec" in p.stderr,
          "missing column: " + p.stderr.strip())

if failures:
    print("%d failures" % len(failures))
    sys.exit(1)
print("all passed")
