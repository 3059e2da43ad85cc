#!/usr/bin/python3
"""guideway map fit against an independent numpy evaluation of the same least squares (docs/map.md):

1. a traverse alone: the carriage's pitch and yaw as Legendre series over the travel, a zero per pass and
   channel and a drift per channel, weighted least squares with the noise estimated from the residuals;
   numpy's lstsq gives the same coefficients and standard uncertainties at the orders the map chose;
2. an artifact alone: each displacement direction its function plus an offset (and across, the artifact's
   alignment slope), each angle its function plus a zero, the artifact's stated uncertainties (a target's own
   part, u / sqrt 2) widened by the residuals' scatter when larger; the same coefficients and uncertainties;
3. the volumetric accuracy: the map's file evaluated by numpy through the first-order chain (bed -> Y -> X -> Z
   -> tool) on the grid, the least-squares rigid body taken out, the largest length: the figure the map reports.

usage: map_numpy_test.py GUIDEWAY MACHINE_TOML WORKDIR
"""
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np

GUIDEWAY, MACHINE, WORK = sys.argv[1:4]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from process_support import Checks  # noqa: E402

check = Checks()
ARCSEC = math.pi / (180 * 3600)


def run(*args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit("command failed (%d): %s\n%s%s" % (r.returncode, " ".join(args), r.stdout, r.stderr))
    return r.stdout


def legendre(xi, orders):
    """P_k(xi) for each k in orders (columns)."""
    n = max(orders)
    p = [np.ones_like(xi), xi]
    for k in range(1, n):
        p.append(((2 * k + 1) * xi * p[k] - k * p[k - 1]) / (k + 1))
    return np.column_stack([p[k] for k in orders])


def read_csv(path):
    meta, rows, header = {}, [], None
    for line in open(path):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            if "=" in line:
                k, v = line[1:].split("=", 1)
                meta[k.strip()] = v.strip()
            continue
        if header is None:
            header = line.split(",")
            continue
        rows.append([float(c) for c in line.split(",")])
    return meta, header, np.array(rows)


def function(mapj, name):
    return next(f for f in mapj["functions"] if f["name"] == name)


def travel(mapj, axis):
    lo, hi = mapj["travel_mm"][axis]
    return lo * 1e-3, hi * 1e-3


def map_u(mapj, f):
    """The standard uncertainties of a function's coefficients from the map's covariance (um or urad)."""
    first = f["first_parameter"]
    cov = np.array(mapj["covariance"])
    return np.sqrt(np.diag(cov)[first:first + len(f["orders"])])


def wls(a, y, w):
    sw = np.sqrt(w)
    x, *_ = np.linalg.lstsq(a * sw[:, None], y * sw, rcond=None)
    cov = np.linalg.inv((a * w[:, None]).T @ a)
    return x, cov


if os.path.exists(WORK):
    shutil.rmtree(WORK)
os.makedirs(WORK)
day = os.path.join(WORK, "day")
run(GUIDEWAY, "simulate", "day", "--machine", MACHINE, "--out-dir", day, "--planes", "", "--no-runout")

# ---- 1. a traverse alone ----
for axis in "xy":
    out = os.path.join(WORK, "traverse_%s.json" % axis)
    run(GUIDEWAY, "map", "fit", "--traverse", os.path.join(day, "traverse_%s.csv" % axis), "--out", out, "--quiet")
    m = json.load(open(out))
    meta, header, t = read_csv(os.path.join(day, "traverse_%s.csv" % axis))
    check(meta.get("axis") == axis, "traverse %s: the file names its axis" % axis)
    col = {h: i for i, h in enumerate(header)}
    u = t[:, col["x_mm"]] * 1e-3
    lo, hi = travel(m, axis)
    xi = (2 * u - lo - hi) / (hi - lo)
    # The file's slopes as the carriage's rotations (docs/conventions.md): X pitch -1, yaw +1; Y pitch +1, yaw -1.
    sp, sy = (-1.0, 1.0) if axis == "x" else (1.0, -1.0)
    pitch_name = {"x": "EBX", "y": "EAY"}[axis]
    yaw_name = {"x": "ECX", "y": "ECY"}[axis]
    fp, fy = function(m, pitch_name), function(m, yaw_name)
    passes = sorted(set(t[:, col["pass"]].astype(int)))
    n = len(u)
    y = np.concatenate([sp * t[:, col["pitch_arcsec"]], sy * t[:, col["yaw_arcsec"]]]) * ARCSEC
    tt = t[:, col["t_s"]]
    tm = 0.5 * (tt.min() + tt.max())
    bp, by = legendre(xi, fp["orders"]), legendre(xi, fy["orders"])
    cols = [np.concatenate([bp, np.zeros_like(bp)]), np.concatenate([np.zeros_like(by), by])]
    for p in passes:
        on = (t[:, col["pass"]] == p).astype(float)
        cols.append(np.concatenate([on, np.zeros(n)])[:, None])
        cols.append(np.concatenate([np.zeros(n), on])[:, None])
    cols.append(np.concatenate([tt - tm, np.zeros(n)])[:, None])
    cols.append(np.concatenate([np.zeros(n), tt - tm])[:, None])
    a = np.hstack(cols)
    x, cov = wls(a, y, np.ones(2 * n))
    r = y - a @ x
    s2 = r @ r / (len(y) - a.shape[1])
    k = len(fp["orders"])
    ours = np.array(fp["coefficients"] + fy["coefficients"])  # urad
    ref = x[: k + len(fy["orders"])] * 1e6
    check(np.allclose(ours, ref, rtol=1e-6, atol=1e-6), "traverse %s: coefficients %s vs numpy %s" % (axis, ours, ref))
    u_ours = np.concatenate([map_u(m, fp), map_u(m, fy)])
    u_ref = np.sqrt(np.diag(cov * s2))[: len(ref)] * 1e6
    check(np.allclose(u_ours, u_ref, rtol=1e-4), "traverse %s: u %s vs numpy %s" % (axis, u_ours, u_ref))

# ---- 2. an artifact alone ----
out = os.path.join(WORK, "artifact_x.json")
run(GUIDEWAY, "map", "fit", "--artifact", os.path.join(day, "artifact_x"), "--out", out, "--quiet")
m = json.load(open(out))
art = json.loads(run(GUIDEWAY, "identify", "artifact", "--calibration", os.path.join(day, "artifact_x", "calibration.csv"),
                     "--horizontal", os.path.join(day, "artifact_x", "horizontal.csv"), "--vertical",
                     os.path.join(day, "artifact_x", "vertical.csv"), "--json"))
targets = art["targets"]
u = np.array([t["x_mm"] for t in targets]) * 1e-3
lo, hi = travel(m, "x")
xi = (2 * u - lo - hi) / (hi - lo)
mid = u.mean()
for comp, name, across in (("dx", "EXX", False), ("dy", "EYX", True), ("dz", "EZX", True)):
    f = function(m, name)
    y = np.array([t[comp + "_um"] for t in targets]) * 1e-6
    us = np.array([t["u_" + comp + "_um"] for t in targets]) * 1e-6
    sig = np.where(np.arange(len(us)) == 0, us[1], us) / math.sqrt(2)
    cols = [legendre(xi, f["orders"]), np.ones((len(u), 1))]
    if across:
        cols.append((u - mid)[:, None])
    a = np.hstack(cols)
    w = 1 / sig**2
    x, cov = wls(a, y, w)
    k = len(f["orders"])
    check(np.allclose(f["coefficients"], x[:k] * 1e6, rtol=1e-6, atol=1e-7),
          "artifact %s: coefficients %s vs numpy %s" % (name, f["coefficients"], x[:k] * 1e6))
    # The map's noise factor is the group's (three directions together): compare the u with it taken out.
    ratio = map_u(m, f) / (np.sqrt(np.diag(cov))[:k] * 1e6)
    check(np.all(ratio >= 1 - 1e-6), "artifact %s: u never below the stated (ratio %s)" % (name, ratio))
    check(np.allclose(ratio, ratio[0], rtol=1e-6), "artifact %s: one noise factor for the group (%s)" % (name, ratio))

# ---- 3. the volumetric accuracy of a full map, recomputed ----
out = os.path.join(WORK, "full.json")
run(GUIDEWAY, "simulate", "day", "--machine", MACHINE, "--out-dir", os.path.join(WORK, "full"), "--no-runout")
run(GUIDEWAY, "map", "fit", "--day", os.path.join(WORK, "full", "day.json"), "--out", out, "--quiet", "--grid", "7")
m = json.load(open(out))
tool = np.array(m["tool_offset_mm"]) * 1e-3
axes = "xyz"
level = {a: m["chain"].index(a) for a in axes}
grid = [np.linspace(*[v * 1e-3 for v in m["travel_mm"][a]], 7) for a in axes]
pts = np.array([[x, y, z] for z in grid[2] for y in grid[1] for x in grid[0]])


def value(name, axis, pos):
    f = function(m, name)
    if not f["determined"]:
        return 0.0
    lo, hi = travel(m, "xyz"[axis])
    xi = (2 * pos - lo - hi) / (hi - lo)
    return float(legendre(np.array([xi]), f["orders"])[0] @ np.array(f["coefficients"])) * 1e-6


q = {s["plane"]: s.get("value_urad", 0.0) * 1e-6 for s in m["squareness"]}
errs = []
for p in pts:
    e = np.zeros(3)
    for j, a in enumerate(axes):
        arm = tool.copy()
        for i, b in enumerate(axes):
            if level[b] > level[a]:
                arm[i] += p[i]
        d = np.array([value("E" + c + a.upper(), j, p[j]) for c in "XYZ"])
        w = np.array([value("E" + c + a.upper(), j, p[j]) for c in "ABC"])
        e += d + np.cross(w, arm)
    e[0] += q["xy"] * p[1] + q["xz"] * p[2]
    e[1] += q["yz"] * p[2]
    errs.append(e)
errs = np.array(errs)
c = pts.mean(axis=0)
rows = []
for p in pts:
    r = p - c
    rows.append(np.array([[1, 0, 0, 0, r[2], -r[1]], [0, 1, 0, -r[2], 0, r[0]], [0, 0, 1, r[1], -r[0], 0]]))
b = np.vstack(rows)
x, *_ = np.linalg.lstsq(b, errs.reshape(-1), rcond=None)
rel = (errs.reshape(-1) - b @ x).reshape(-1, 3)
va = np.max(np.linalg.norm(rel, axis=1)) * 1e6
ours = m["volumetric"]["value_um"]
check(abs(va - ours) < 1e-6 * max(1.0, ours), "volumetric accuracy %.6f um vs numpy %.6f um" % (ours, va))

sys.exit(check.finish("map_numpy_test: the map agrees with numpy"))
