#!/usr/bin/python3
"""`guideway-emulate artifact` + `guideway identify artifact` end to end, numpy as the oracle.

Usage: artifact_cli_test.py GUIDEWAY GUIDEWAY_EMULATE MACHINE_TOML

Wei's equations (Secs. 3.1-3.3) are re-evaluated with numpy from the three CSV files and compared
with the JSON; the uncertainties are compared with the closed form that follows from them (the
mirror spots cancel from the corrected positions: u(d)^2 = 4 k^2 u_spot^2 + 2 u_laser^2 + 2 u_machine^2,
u(epsilon) = 2 u_spot / m); bad files give "guideway: FILE:LINE: message".
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

GUIDEWAY, EMULATE, MACHINE = sys.argv[1], sys.argv[2], sys.argv[3]
ARCSEC = np.pi / (180 * 3600)
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def read(path):
    meta, rows, header = {}, [], None
    for line in open(path):
        line = line.strip()
        if line.startswith("#"):
            if "=" in line:
                k, v = line[1:].split("=", 1)
                meta[k.strip()] = v.strip()
            continue
        if not line:
            continue
        if header is None:
            header = line.split(",")
            continue
        rows.append([float(c) for c in line.split(",")])
    a = np.array(rows)
    return meta, {h: a[:, i] for i, h in enumerate(header)}


def placement(c, k, m, across):
    th_x = (c["y_F_px"] - c["y_F_px"][0]) / m
    th_y = (c["x_F_px"] - c["x_F_px"][0]) / m
    XF = k * (c["x_M_px"][0] - c["x_F_px"][0]) + (c["X_M_mm"] - c["X_M_mm"][0]) * 1e-3 + k * (c["x_F_px"] - c["x_M_px"])
    YF = k * (c["y_M_px"][0] - c["y_F_px"][0]) + (c[across] - c[across][0]) * 1e-3 + k * (c["y_F_px"] - c["y_M_px"])
    return th_x, th_y, XF, YF


with tempfile.TemporaryDirectory() as d:
    p = subprocess.run([EMULATE, "artifact", "--machine", MACHINE, "--out-dir", d, "--seed", "5"],
                       capture_output=True, text=True, timeout=60)
    check(p.returncode == 0, "guideway-emulate artifact runs: " + p.stderr.strip())
    cal, hor, ver = (os.path.join(d, n + ".csv") for n in ("calibration", "horizontal", "vertical"))
    args = [GUIDEWAY, "identify", "artifact", "--calibration", cal, "--horizontal", hor, "--vertical", ver]
    p = subprocess.run(args + ["--json"], capture_output=True, text=True, timeout=60)
    check(p.returncode == 0, "identify artifact --json runs: " + p.stderr.strip())
    r = json.loads(p.stdout)
    mc, c = read(cal)
    mh, h = read(hor)
    mv, v = read(ver)
    k = float(mc["k_um_per_px"]) * 1e-6
    m = float(mc["m_px_per_arcsec"]) / ARCSEC
    cx, cy, cX, cY = placement(c, k, m, "Y_M_mm")
    hx, hy, hX, hY = placement(h, k, m, "Y_M_mm")
    vx, vy, vX, vY = placement(v, k, m, "Z_M_mm")
    ex, ey, ez, exv = hx - cx, hy - cy, vy - cy, vx - cx
    dx = -(hX - cX - k * m * ey)
    dy = -(hY - cY - k * m * ex)
    dz = -(vY - cY - k * m * exv)
    us, ul = float(mc["u_spot_px"]), float(mc["u_position_um"]) * 1e-6
    u_pos = np.sqrt(4 * k * k * us * us + 2 * ul * ul)
    u_ang = 2 * us / m
    worst_v, worst_u = 0.0, 0.0
    for i, t in enumerate(r["targets"]):
        for name, ref, scale in (("dx_um", dx, 1e6), ("dy_um", dy, 1e6), ("dz_um", dz, 1e6),
                                 ("ex_arcsec", ex, 1 / ARCSEC), ("ey_arcsec", ey, 1 / ARCSEC),
                                 ("ez_arcsec", ez, 1 / ARCSEC)):
            worst_v = max(worst_v, abs(t[name] - ref[i] * scale))
            uref = 0.0 if i == 0 else (u_pos * 1e6 if name.endswith("_um") else u_ang / ARCSEC)
            worst_u = max(worst_u, abs(t["u_" + name] - uref))
    check(worst_v < 1e-9, "values match numpy's Wei equations (worst %.2e)" % worst_v)
    check(worst_u < 1e-9, "uncertainties match the closed form (worst %.2e; u(d) %.4f um, u(eps) %.4f arcsec)"
          % (worst_u, u_pos * 1e6, u_ang / ARCSEC))
    for i, t in enumerate(r["horizontal"]):
        check(abs(t["X_F_mm"] - hX[i] * 1e3) < 1e-12 and abs(t["theta_y_arcsec"] - hy[i] / ARCSEC) < 1e-9,
              "horizontal feature point %d: X_F %.6f mm" % (i, t["X_F_mm"])) if i in (1, 8) else None
    p = subprocess.run(args, capture_output=True, text=True, timeout=60)
    check(p.returncode == 0 and "dx_um" in p.stdout and len(p.stdout.splitlines()) == 3 + 9, "text table")

    # k and m from the scans (Wei Sec. 3.2): line fits against numpy's lstsq.
    ks, ms_ = os.path.join(d, "k_scan.csv"), os.path.join(d, "m_scan.csv")
    p = subprocess.run(args + ["--k-scan", ks, "--m-scan", ms_, "--json"], capture_output=True, text=True, timeout=60)
    check(p.returncode == 0, "identify artifact with scans runs: " + p.stderr.strip())
    rs = json.loads(p.stdout)
    for path, xcol, ycol, scale, key, conv in ((ks, "X_M_mm", "x_M_px", 1e-3, "k_um_per_px", "k"),
                                               (ms_, "theta_arcsec", "x_F_px", ARCSEC, "m_px_per_arcsec", "m")):
        _, sc = read(path)
        x, y = sc[xcol] * scale, sc[ycol]
        J = np.column_stack([np.ones_like(x), x])
        sol, *_ = np.linalg.lstsq(J, y, rcond=None)
        res = y - J @ sol
        u_slope = np.sqrt(res @ res / (len(x) - 2) * np.linalg.inv(J.T @ J)[1, 1])
        if conv == "k":
            val, u = 1e6 / sol[1], 1e6 * u_slope / sol[1] ** 2
        else:
            val, u = sol[1] * ARCSEC, u_slope * ARCSEC
        check(abs(rs[key] - val) < 1e-9 * val and abs(rs["u_" + key] - u) < 1e-6 * u,
              "%s from the scan %.6f (u %.6f), numpy %.6f (u %.6f)" % (conv, rs[key], rs["u_" + key], val, u))
    check(abs(rs["k_um_per_px"] - 1.6) < 3 * rs["u_k_um_per_px"], "k scan recovers the sensor's 1.6 um/px")

    # Bad input: a non-numeric spot, a vertical file given as the horizontal one, a short machine file.
    lines = open(hor).read().splitlines()
    hdr = next(i for i, l in enumerate(lines) if l.startswith("target"))
    cells = lines[hdr + 3].split(",")
    cells[4] = "n/a"
    lines[hdr + 3] = ",".join(cells)
    bad = os.path.join(d, "bad.csv")
    open(bad, "w").write("\n".join(lines) + "\n")
    p = subprocess.run([GUIDEWAY, "identify", "artifact", "--calibration", cal, "--horizontal", bad, "--vertical", ver],
                       capture_output=True, text=True, timeout=60)
    check(p.returncode == 1 and p.stderr.startswith("guideway: %s:%d: column 'y_M_px'" % (bad, hdr + 4)),
          "non-numeric cell: " + p.stderr.strip())
    p = subprocess.run([GUIDEWAY, "identify", "artifact", "--calibration", cal, "--horizontal", ver, "--vertical", ver],
                       capture_output=True, text=True, timeout=60)
    check(p.returncode == 1 and "placement is 'vertical', expected 'horizontal'" in p.stderr,
          "wrong placement: " + p.stderr.strip())
    short = os.path.join(d, "short.csv")
    open(short, "w").write("\n".join(open(hor).read().splitlines()[:-2]) + "\n")
    p = subprocess.run([GUIDEWAY, "identify", "artifact", "--calibration", cal, "--horizontal", short, "--vertical",
                        ver], capture_output=True, text=True, timeout=60)
    check(p.returncode == 1 and "%s: 7 targets, but the calibration %s has 9" % (short, cal) in p.stderr,
          "mismatched lengths: " + p.stderr.strip())
    # Every required option missing is named at once (CLI11 alone names the first).
    p = subprocess.run([GUIDEWAY, "identify", "artifact", "--vertical", ver], capture_output=True, text=True, timeout=60)
    check(p.returncode != 0 and "guideway identify artifact: missing --calibration, --horizontal" in p.stderr,
          "missing options: " + p.stderr.strip())
    # One missing is said in the same form (not CLI11's own "--calibration is required").
    p = subprocess.run([GUIDEWAY, "identify", "artifact", "--vertical", ver, "--horizontal", hor], capture_output=True,
                       text=True, timeout=60)
    check(p.returncode != 0 and p.stderr.startswith(
        "guideway identify artifact: missing --calibration (required; identify artifact --help says what it is)"),
          "one missing option: " + p.stderr.strip())

if failures:
    print("%d failures" % len(failures))
    sys.exit(1)
print("all passed")
