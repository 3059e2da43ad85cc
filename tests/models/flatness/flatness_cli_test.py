#!/usr/bin/python3
"""`guideway identify straightness|unionjack|runout` end to end, with numpy as the oracle.

Usage: flatness_cli_test.py GUIDEWAY_BINARY MOODY_DIR

- unionjack: Moody 1955 reproduced (reference_heights.dat, tolerance 2e-5 tens of micro-inch), and a
  single-precision emulation of the worksheet (the reference's arithmetic: float32, pi = 3.141592)
  shown to reach the printed precision (5e-7), so the remaining double-vs-reference difference is the
  reference's rounding; --least-squares against numpy.linalg.lstsq (1e-9 um).
- straightness and runout: against numpy integrations and fits; bad files give "file:line" errors.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

GUIDEWAY, MOODY = sys.argv[1], sys.argv[2]
NAMES = ["NW_SE", "NE_SW", "NE_NW", "NE_SE", "SE_SW", "NW_SW", "E_W", "N_S"]
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def run(*args):
    p = subprocess.run([GUIDEWAY, "identify", *args], capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def readings(name, d=MOODY):
    with open(os.path.join(d, name + ".txt")) as f:
        return np.array([float(l) for l in f if l.strip() and not l.startswith("#")])


def reference():
    ref, cur = {}, None
    for line in open(os.path.join(MOODY, "reference_heights.dat")):
        if line.startswith("# ") and line.strip().endswith(".txt"):
            cur = line.strip()[2:-4]
            ref[cur] = []
        elif line.strip() and not line.startswith("#"):
            ref[cur].append([float(v) for v in line.split()])
    return {k: np.array(v) for k, v in ref.items()}


def worksheet_float32():
    """Moody's worksheet columns in single precision (independent re-statement of the procedure)."""
    f32 = np.float32
    arc = f32(2.0 * 3.141592 / (360.0 * 3600))

    def column4(r):  # sum of (reading - first reading), station 0 and 1 at zero
        r = r.astype(f32)
        c = np.zeros(len(r) + 1, f32)
        for j in range(2, len(r) + 1):
            c[j] = f32(c[j - 1] + f32(r[j - 1] - r[0]))
        return c

    def diagonal(r):
        c, n = column4(r), len(r)
        a, b = f32(-c[n] / f32(n)), f32(f32(0.5) * c[n] - c[n // 2])
        return np.array([f32(c[j] + f32(a * f32(j) + b)) for j in range(n + 1)], f32)

    def between(r, h0, h1):
        c, n = column4(r), len(r)
        corr, h = np.zeros(n + 1, f32), np.zeros(n + 1, f32)
        corr[0] = h[0] = h0
        h[n] = h1
        corr[n] = f32(h1 - c[n])
        step = f32((corr[0] - corr[n]) / f32(n))
        for j in range(n - 1, 0, -1):
            corr[j] = f32(corr[j + 1] + step)
            h[j] = f32(corr[j] + c[j])
        return h

    H = {"NW_SE": diagonal(readings("NW_SE")), "NE_SW": diagonal(readings("NE_SW"))}
    nw, se, ne, sw = H["NW_SE"][0], H["NW_SE"][-1], H["NE_SW"][0], H["NE_SW"][-1]
    H["NE_NW"] = between(readings("NE_NW"), ne, nw)
    H["NE_SE"] = between(readings("NE_SE"), ne, se)
    H["SE_SW"] = between(readings("SE_SW"), se, sw)
    H["NW_SW"] = between(readings("NW_SW"), nw, sw)
    for name, a, b in (("E_W", "NE_SE", "NW_SW"), ("N_S", "NE_NW", "SE_SW")):
        h = between(readings(name), H[a][len(H[a]) // 2], H[b][len(H[b]) // 2])
        H[name] = (h - h[len(h) // 2]).astype(f32)
    lo = min(v.min() for v in H.values())
    scale = f32(4.0 * 100000.0)
    return {k: np.array([f32(f32(f32(v - lo) * arc) * scale) for v in h]) for k, h in H.items()}


# --- Union Jack -------------------------------------------------------------------------------------
ref = reference()
rc, out, err = run("unionjack", MOODY, "--json", "--least-squares")
check(rc == 0, "unionjack exits 0 " + err.strip())
uj = json.loads(out)
worst = 0.0
for line in uj["lines"]:
    h = np.array([s["height_10uin"] for s in line["stations"]])
    xy = np.array([[s["x_steps"], s["y_steps"]] for s in line["stations"]])
    check(np.allclose(xy, ref[line["name"]][:, :2], atol=1e-6), line["name"] + " station coordinates")
    worst = max(worst, np.abs(h - ref[line["name"]][:, 2]).max())
check(worst <= 2e-5, "Moody 1955 reproduced in double precision: max |dev| %.3g (<= 2e-5) tens of micro-inch" % worst)
ws = worksheet_float32()
w32 = max(np.abs(ws[k] - ref[k][:, 2]).max() for k in NAMES)
check(w32 <= 5e-7, "single-precision worksheet reaches the printed precision: max |dev| %.3g (<= 5e-7)" % w32)
check(abs(uj["closure"]["E_W_10uin"] + 1.357478) < 2e-5, "E_W closure -1.357478 tens of micro-inch")

# Least squares: numpy.linalg.lstsq on the same observation equations, built here from the readings.
s_m = uj["foot_spacing_mm"] * 1e-3
key = lambda x, y: (round(x * 1e6), round(y * 1e6))
index, rows, rhs = {}, [], []
for line in uj["lines"]:
    for st in line["stations"]:
        index.setdefault(key(st["x_steps"], st["y_steps"]), len(index))
U = len(index)
for i, line in enumerate(uj["lines"]):
    r = readings(line["name"])
    st = line["stations"]
    for j, a in enumerate(r):
        row = np.zeros(U + 8)
        row[index[key(st[j + 1]["x_steps"], st[j + 1]["y_steps"])]] += 1
        row[index[key(st[j]["x_steps"], st[j]["y_steps"])]] -= 1
        row[U + i] = -1
        rows.append(row)
        rhs.append(s_m * np.tan(np.radians(a / 3600.0)))
A, y = np.array(rows), np.array(rhs)
sol, _, rank, _ = np.linalg.lstsq(A, y, rcond=None)
coords = np.zeros((U, 2))
for k, i in index.items():
    coords[i] = np.array(k) / 1e6
P = np.column_stack([np.ones(U), coords])
h = sol[:U] - P @ np.linalg.lstsq(P, sol[:U], rcond=None)[0]
lsq = uj["least_squares"]
ours = np.array([s["height_um"] for s in lsq["stations"]])
ours_idx = [index[key(s["x_steps"], s["y_steps"])] for s in lsq["stations"]]
dev = np.abs(ours - h[ours_idx] * 1e6).max()
check(len(ours) == U and dev < 1e-9, "--least-squares equals numpy lstsq: max |dev| %.2g um over %d stations" % (dev, U))
check(lsq["redundancy"] == len(y) - rank, "redundancy %d = readings - rank" % lsq["redundancy"])

# Minimum zone against scipy's linprog: min w s.t. a x + b y + c <= z <= a x + b y + c + w.
from scipy.optimize import linprog


def zone(pts):
    pts = np.asarray(pts)
    n = len(pts)
    X = np.column_stack([pts[:, 0], pts[:, 1], np.ones(n)])
    A = np.vstack([np.column_stack([X, np.zeros(n)]), np.column_stack([-X, -np.ones(n)])])
    b = np.concatenate([pts[:, 2], -pts[:, 2]])
    res = linprog([0, 0, 0, 1], A_ub=A, b_ub=b, bounds=[(None, None)] * 4, method="highs")
    return res.fun


moody_pts = [(s["x_steps"], s["y_steps"], s["height_um"]) for line in uj["lines"] for s in line["stations"]]
z_ref = zone(moody_pts)
check(abs(uj["flatness_min_zone_um"] - z_ref) < 1e-7, "Moody minimum zone %.6f um equals scipy linprog %.6f" % (uj["flatness_min_zone_um"], z_ref))
lsq_pts = [(s["x_steps"], s["y_steps"], s["height_um"]) for s in lsq["stations"]]
z_ref = zone(lsq_pts)
check(abs(lsq["flatness_min_zone_um"] - z_ref) < 1e-7, "least-squares minimum zone %.6f um equals scipy linprog %.6f" % (lsq["flatness_min_zone_um"], z_ref))

# --- Straightness -----------------------------------------------------------------------------------
tmp = tempfile.mkdtemp(prefix="gw-flat-")
rng = np.random.default_rng(5)
x = np.arange(0, 600, 10.0)
pitch = 2.0 + 1.5 * np.sin(x / 95.0) + rng.normal(0, 0.3, x.size)
yaw = -1.0 + 0.002 * x + rng.normal(0, 0.3, x.size)
path = os.path.join(tmp, "angles.csv")
with open(path, "w") as f:
    f.write("# step_mm = 10\nx_mm,pitch_arcsec,yaw_arcsec\n")
    for row in zip(x, pitch, yaw):
        f.write("%.17g,%.17g,%.17g\n" % row)
rc, out, err = run("straightness", path, "--json")
check(rc == 0, "straightness exits 0 " + err.strip())
st = json.loads(out)
for plane, ang in (("vertical", pitch), ("horizontal", yaw)):
    hh = np.concatenate([[0], np.cumsum(10e-3 * np.tan(np.radians(ang / 3600)))]) * 1e6
    got = np.array([s["height_um"] for s in st[plane]["stations"]])
    check(np.abs(got - hh).max() < 1e-9, plane + " heights equal numpy cumsum(step*tan)")
    xs = np.arange(hh.size) * 10.0
    res = hh - np.polyval(np.polyfit(xs, hh, 1), xs)
    check(abs(st[plane]["least_squares"]["straightness_um"] - np.ptp(res)) < 1e-9, plane + " least-squares straightness equals numpy polyfit")
    check(st[plane]["minimum_zone"]["straightness_um"] <= np.ptp(res) + 1e-12, plane + " minimum zone <= least squares")

bad = {
    "missing.csv": ("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,2\n30,3\n", "missing.csv:5: missing station"),
    "text.csv": ("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,n/a\n", "text.csv:4: column 'pitch_arcsec': 'n/a' is not a finite number"),
    "range.csv": ("# step_mm = 10\nx_mm,pitch_arcsec\n0,-560\n10,650\n",
                  "range.csv:4: pitch_arcsec spans 1210\" (from -560 at "),
}
for name, (text, msg) in bad.items():
    p = os.path.join(tmp, name)
    open(p, "w").write(text)
    rc, out, err = run("straightness", p)
    check(rc == 1 and msg in err, "bad traverse %s -> %s" % (name, err.strip()))

# --- Run-out ----------------------------------------------------------------------------------------
def write_runout(path, ang, z, metadata="# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n"):
    with open(path, "w") as f:
        f.write(metadata + "angle_deg,runout_um\n")
        for row in zip(ang, z):
            f.write("%.17g,%.17g\n" % row)


ang = np.arange(0, 360, 2.0)
z = 0.7 + 0.15 * np.cos(np.radians(ang - 75)) + rng.normal(0, 0.01, ang.size)
path = os.path.join(tmp, "runout.csv")
write_runout(path, ang, z, "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# travel_mm = 600\n")
rc, out, err = run("runout", path, "--json")
check(rc == 0, "runout exits 0 " + err.strip())
ro = json.loads(out)
phi = np.radians(ang)
J = np.column_stack([np.ones_like(phi), np.cos(phi), np.sin(phi), np.cos(2 * phi), np.sin(2 * phi)])
c = np.linalg.lstsq(J, z, rcond=None)[0]
amp = np.hypot(c[1], c[2])
check(abs(ro["once_per_rev"]["amplitude_um"] - amp) < 1e-12, "run-out amplitude equals numpy lstsq (%.4f um)" % amp)
check(abs(ro["deflection_urad"] - (2 * amp + 2.5) / 1000 * 1e3) < 1e-9, "deflection (r + p) / L")
check(abs(ro["squareness_amplitude_um"] - ro["deflection_urad"] * 0.6) < 1e-9, "squareness amplitude over 600 mm")

check(ro.get("error_motion", {}).get("revolutions") == 1,
      "a revolution sampled every 2 deg up to 358 deg is one whole revolution: %s" % ro.get("error_motion"))


# --- Run-out over several revolutions: ISO 230-7 error motion against numpy --------------------------------
def iso230_7(a_deg, z):
    """Total, synchronous and asynchronous error motion, the once-per-revolution term removed (numpy)."""
    a = np.radians(a_deg)
    step = (a[-1] - a[0]) / (a.size - 1)
    revs = int(np.floor((a[-1] - a[0] + step) / (2 * np.pi) + 1e-6))
    keep = a < a[0] + 2 * np.pi * revs * (1 - 1e-12)
    a, z = a[keep], z[keep]
    J = np.column_stack([np.ones_like(a), np.cos(a), np.sin(a)])
    e = z - J @ np.linalg.lstsq(J, z, rcond=None)[0]
    m = int(np.clip(a.size // revs, 8, 3600))
    grid = np.interp(2 * np.pi * np.arange(m * revs) / m, a - a[0], e).reshape(revs, m)
    return revs, np.ptp(e), np.ptp(grid.mean(axis=0)), np.ptp(grid, axis=0).max()


# 12.3 revolutions, 91 readings per revolution with jittered angles (live time stamps), a 3rd and a 5th
# harmonic, a line at 3.7 per revolution and growth: every value against numpy's.
n = int(12.3 * 91)
ang = (np.arange(n) + rng.uniform(-0.3, 0.3, n)) * 360.0 / 91 + 17.0
phi = np.radians(ang)
z = (0.2 * np.cos(phi - 1) + 0.12 * np.cos(3 * phi + 0.7) + 0.03 * np.sin(5 * phi) + 0.08 * np.cos(3.7 * phi)
     + 0.002 * phi + rng.normal(0, 0.01, n))
path = os.path.join(tmp, "runout_revs.csv")
write_runout(path, ang, z)
rc, out, err = run("runout", path, "--json")
check(rc == 0, "runout of 12.3 revolutions exits 0 " + err.strip())
em = json.loads(out)["error_motion"]
revs, total, sync, asyn = iso230_7(ang, z)
check(em["revolutions"] == revs == 12, "12 whole revolutions (%s)" % em["revolutions"])
for name, ref in (("total", total), ("synchronous", sync), ("asynchronous", asyn)):
    got = em[name + "_error_motion_um"]
    check(abs(got - ref) < 1e-9, "%s error motion %.6f um equals numpy's %.6f um" % (name, got, ref))
rc, out, err = run("runout", path)
check("synchronous error motion = " in out and "over 12 revolutions" in out, "the text names the figures: " + out)

# Closed form: a 3rd harmonic of 0.1 um alone repeats every revolution: synchronous = total = 0.2 um, no
# asynchronous part; the once-per-revolution lean is removed first.
ang = np.arange(0, 360 * 5, 1.0)
phi = np.radians(ang)
write_runout(path, ang, 0.5 * np.cos(phi) + 0.1 * np.cos(3 * phi))
em = json.loads(run("runout", path, "--json")[1])["error_motion"]
check(abs(em["synchronous_error_motion_um"] - 0.2) < 1e-6 and abs(em["total_error_motion_um"] - 0.2) < 1e-6
      and em["asynchronous_error_motion_um"] < 1e-9 and abs(em["fundamental_um"] - 0.5) < 1e-9,
      "a 3rd harmonic of 0.1 um: synchronous = total = 0.2 um, asynchronous 0 (%s)" % em)

# --- Donaldson's reversal: the spindle's synchronous error motion with the plate's form removed ----------
# Simulated here (not by the project's machine): the spindle's 3rd harmonic and twice-per-revolution motion
# stay at their spindle angle, the plate's 3rd, 4th and 5th lobes turn with it by 180 deg in the second
# record; 8 revolutions of 90 readings, angles from the spindle's zero. numpy: the average revolutions'
# FFTs, spindle = (A + B) / 2 at every order, form = (A - B) / 2 at the odd orders (an even order's form a
# half turn brings back onto itself: it stays in the spindle's figure), the mean and the Nyquist order out.
def average_revolution(a_deg, z):
    a = np.radians(a_deg)
    revs = int(np.floor((a[-1] - a[0] + (a[1] - a[0])) / (2 * np.pi) + 1e-6))
    J = np.column_stack([np.ones_like(a), np.cos(a), np.sin(a)])
    e = z - J @ np.linalg.lstsq(J, z, rcond=None)[0]
    m = a.size // revs
    return np.interp(2 * np.pi * np.arange(m * revs) / m, a - a[0], e).reshape(revs, m).mean(axis=0)


spindle = lambda t: 0.08 * np.cos(3 * t + 0.3) + 0.05 * np.cos(2 * t)
form = lambda t: 0.05 * np.cos(3 * t + 1.2) + 0.03 * np.cos(5 * t - 0.4) + 0.02 * np.cos(4 * t)
ang = np.arange(8 * 90) * 4.0
phi = np.radians(ang)
za = 0.15 * np.cos(phi - 0.5) + spindle(phi) + form(phi) + rng.normal(0, 0.005, phi.size)
zb = 0.12 * np.cos(phi + 0.9) + spindle(phi) + form(phi - np.pi) + rng.normal(0, 0.005, phi.size)
pa, pb = os.path.join(tmp, "plate_0.csv"), os.path.join(tmp, "plate_180.csv")
meta = "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# angle_zero = spindle\n"
write_runout(pa, ang, za, meta + "# artifact_turned_deg = 0\n")
write_runout(pb, ang, zb, meta + "# artifact_turned_deg = 180\n")
rc, out, err = run("runout", pa, pb, "--json")
check(rc == 0, "runout with a reversal exits 0 " + err.strip())
rv = json.loads(out).get("reversal", {})
fa, fb = np.fft.rfft(average_revolution(ang, za)), np.fft.rfft(average_revolution(ang, zb))
fs, ff = (fa + fb) / 2, (fa - fb) / 2
fs[0] = ff[0] = 0
fs[-1] = ff[-1] = 0  # 90 points: order 45 is the Nyquist order
ff[0::2] = 0
ref_spindle, ref_form = np.ptp(np.fft.irfft(fs, 90)), np.ptp(np.fft.irfft(ff, 90))
check(abs(rv.get("spindle_synchronous_error_motion_um", 0) - ref_spindle) < 1e-9,
      "spindle's synchronous error motion %s um equals numpy's %.6f um" % (rv.get("spindle_synchronous_error_motion_um"), ref_spindle))
check(abs(rv.get("artifact_form_um", 0) - ref_form) < 1e-9,
      "artifact's form %s um equals numpy's %.6f um" % (rv.get("artifact_form_um"), ref_form))
t = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
true_spindle = np.ptp(spindle(t) + 0.02 * np.cos(4 * t))  # the form's 4th order stays with the spindle
true_form = np.ptp(0.05 * np.cos(3 * t + 1.2) + 0.03 * np.cos(5 * t - 0.4))
check(abs(ref_spindle - true_spindle) < 0.01 and abs(ref_form - true_form) < 0.01,
      "and near the truth: spindle %.4f (%.4f), form %.4f (%.4f) um" % (ref_spindle, true_spindle, ref_form, true_form))
check(rv.get("together_orders", [])[:3] == [2, 4, 6], "even orders stay together: %s" % rv.get("together_orders"))
rc, out, err = run("runout", pa, pb)
check(rc == 0 and "reversal (Donaldson)" in out and "spindle's synchronous error motion = " in out,
      "the text gives the reversal's figures: " + out)
# Angles from the first reading (the live session's) cannot be compared: refused, naming the file.
write_runout(pb, ang, zb, "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# angle_zero = first_reading\n"
             "# artifact_turned_deg = 180\n")
rc, out, err = run("runout", pa, pb)
check(rc == 1 and "plate_180.csv: its angles count from its first reading" in err, "unreferenced angles refused: " + err.strip())

shutil.rmtree(tmp, ignore_errors=True)
if failures:
    print("%d failure(s)" % len(failures))
    sys.exit(1)
print("all passed")
