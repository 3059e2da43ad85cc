#!/usr/bin/python3
"""The report's SVG writer checked from outside: random data sets are rendered by report_svg_tool, parsed
with Python's XML parser (well-formed, escaped), and the axis mapping is recovered from the tick labels
alone (their printed values against their pixel positions, a least-squares line); the data path read back
through that mapping must give the input data. Polar plots: the ring labels give the radial scale, the
nominal circle the centre; the path's radius and angle must give the input deviations and angles, and the
stated um/division must equal the ring spacing. Ticks must be 1-2-5 multiples covering the data.
An explanation's residual before and after each finding (random curves in the JSON of guideway explain): one
panel per step, titled by the step, every run's curve read back through the panel's axes, one y scale for all.

usage: report_svg_xml_test.py REPORT_SVG_TOOL
"""
import math
import json
import os
import re
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

TOOL = sys.argv[1]
NS = {"s": "http://www.w3.org/2000/svg"}
rng = np.random.default_rng(20261121)
failures = 0


def fail(msg):
    global failures
    failures += 1
    print("FAIL:", msg)


def render(kind, x, y):
    data = "\n".join("%.17g %.17g" % p for p in zip(x, y))
    out = subprocess.run([TOOL, kind], input=data, capture_output=True, text=True, check=True).stdout
    return ET.fromstring(out)  # raises on malformed XML


def cls(e):
    return (e.get("class") or "").split()


def find_class(root, tag, *names):
    return [e for e in root.iter("{%s}%s" % (NS["s"], tag)) if all(n in cls(e) for n in names)]


def path_points(d):
    return [(float(a), float(b)) for a, b in re.findall(r"[ML]\s*(-?[\d.]+)\s+(-?[\d.]+)", d)]


def is_125(step):
    m = step / 10 ** math.floor(math.log10(step) + 1e-9)
    return any(abs(m - k) < 1e-6 for k in (1, 2, 5, 10))


def axis_map(root, which):
    g = find_class(root, "g", "axis", which)
    assert len(g) == 1, "one %s axis" % which
    labels = find_class(g[0], "text", "tick-label")
    vals = np.array([float(t.text) for t in labels])
    pos = np.array([float(t.get("x" if which == "x" else "y")) for t in labels])
    if which == "y":
        pos = pos - 4  # labels sit 4 px below their tick (baseline)
    A = np.column_stack([np.ones_like(vals), vals])
    coef, *_ = np.linalg.lstsq(A, pos, rcond=None)
    resid = np.abs(A @ coef - pos).max()
    return vals, coef, resid


for trial in range(30):
    n = int(rng.integers(5, 400))
    x0 = rng.choice([0.0, -250.0, 1e3, 0.003])
    xs = x0 + np.sort(rng.uniform(0, 10 ** rng.uniform(-2, 3), n))
    scale = 10 ** rng.uniform(-3, 3)
    ys = rng.normal(rng.choice([0.0, 5 * scale, -20 * scale]), scale, n)
    root = render("line", xs, ys)
    title = root.find("s:title", NS)
    if title is None or title.text != "test <&> plot":
        fail("title not escaped/unescaped correctly: %r" % (title.text if title is not None else None))
    maps = {}
    for which in ("x", "y"):
        vals, coef, resid = axis_map(root, which)
        if resid > 0.06:
            fail("trial %d: %s tick labels not on a linear scale (residual %.3f px)" % (trial, which, resid))
        steps = np.diff(vals)
        if len(vals) < 2 or not np.allclose(steps, steps[0], rtol=1e-6) or not is_125(steps[0]):
            fail("trial %d: %s ticks %s not evenly spaced 1-2-5 multiples" % (trial, which, vals))
        maps[which] = coef
    _, ycoef, _ = maps["x"], maps["y"], None
    yvals, _, _ = axis_map(root, "y")
    if yvals.min() > ys.min() + 1e-9 * abs(ys).max() or yvals.max() < ys.max() - 1e-9 * abs(ys).max():
        fail("trial %d: y ticks %s do not cover the data [%g, %g]" % (trial, yvals, ys.min(), ys.max()))
    paths = find_class(root, "path", "data")
    if len(paths) != 1 or paths[0].get("data-series") != 'data "1"':
        fail("trial %d: data path missing or series label wrong" % trial)
        continue
    pts = np.array(path_points(paths[0].get("d")))
    if len(pts) != n:
        fail("trial %d: %d points in the path for %d data" % (trial, len(pts), n))
        continue
    bx, by = maps["x"], maps["y"]
    xr = (pts[:, 0] - bx[0]) / bx[1]
    yr = (pts[:, 1] - by[0]) / by[1]
    # Tick positions are printed to 0.1 px and path points to 0.01 px: allow 0.08 px.
    tol_x = 0.08 / abs(bx[1]) + 1e-12
    tol_y = 0.08 / abs(by[1]) + 1e-12
    if np.abs(xr - xs).max() > tol_x or np.abs(yr - ys).max() > tol_y:
        fail("trial %d: data read back through the tick scale differ: dx %.3g (tol %.3g), dy %.3g (tol %.3g)"
             % (trial, np.abs(xr - xs).max(), tol_x, np.abs(yr - ys).max(), tol_y))
    for lab in find_class(root, "text", "axis-label"):
        if not lab.text or " / " not in lab.text:
            fail("trial %d: axis label without unit: %r" % (trial, lab.text))

for trial in range(15):
    n = 720
    ang = np.linspace(0, 360, n, endpoint=False)
    amp = 10 ** rng.uniform(-1.5, 1.5)
    dev = amp * (np.cos(np.radians(2 * ang)) + 0.3 * rng.normal(size=n))
    root = render("polar", ang, dev)
    nominal = find_class(root, "circle", "nominal")[0]
    cx, cy, r0 = (float(nominal.get(k)) for k in ("cx", "cy", "r"))
    rings = find_class(root, "circle", "ring") + [nominal]
    radii = sorted(float(c.get("r")) for c in rings)
    stated = [t for t in find_class(root, "text", "axis-label") if "div" in (t.text or "")]
    m = re.search(r"([\d.]+) \u00b5m/div", stated[0].text if stated else "")
    per_div = float(m.group(1)) if m else float("nan")
    # The rings are one stated division apart about the bold ring, the value 0: radius = r0 + k * value
    # (radii printed to 0.1 px).
    steps = np.diff(radii)
    ring_of = (np.arange(len(radii)) - len(radii) // 2) * per_div
    coef, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(radii)), ring_of]), np.array(radii), rcond=None)
    if not m or np.abs(steps - steps.mean()).max() > 0.11 or abs(coef[0] - r0) > 0.06:
        fail("polar %d: stated scale %r, rings %s px apart" % (trial, stated[0].text if stated else None, steps))
        continue
    # Ring values (every ring's, or every other's when the rings are close) sit on their rings along 75 deg
    # (the text's baseline 4 px below).
    for t in find_class(root, "text", "ring-label"):
        at = (np.hypot(float(t.get("x")) - cx, float(t.get("y")) - 4 - cy) - coef[0]) / coef[1]
        if abs(at - float(t.text)) > 0.2 / coef[1]:
            fail("polar %d: ring value %s drawn at %g" % (trial, t.text, at))
    vals = list((np.array(radii) - coef[0]) / coef[1])  # the rings' values, labelled or not
    # The scale fills the plot: a 1-2-5 step, 3 to 5 rings out, the largest deviation 63 % to 97 % of the way.
    if (max(abs(dev)) > max(vals) or not is_125(per_div) or not 3 <= round(max(vals) / per_div) <= 5
            or not 0.63 <= max(abs(dev)) / max(vals) <= 0.975):
        fail("polar %d: scale %g um/div, %d rings out, for max |dev| %g: does not fill the plot"
             % (trial, per_div, round(max(vals) / per_div), max(abs(dev))))
    pts = np.array(path_points(find_class(root, "path", "data")[0].get("d")))
    rad = np.hypot(pts[:, 0] - cx, pts[:, 1] - cy)
    back = (rad - coef[0]) / coef[1]
    th = np.degrees(np.arctan2(-(pts[:, 1] - cy), pts[:, 0] - cx)) % 360
    if np.abs(back - dev).max() > 0.05 / coef[1] + 1e-9:
        fail("polar %d: deviations read back differ by %g um" % (trial, np.abs(back - dev).max()))
    dth = np.abs((th - ang + 180) % 360 - 180)
    if dth.max() > 0.05:
        fail("polar %d: angles read back differ by %g deg" % (trial, dth.max()))

for trial in range(5):
    n = int(rng.integers(50, 720))
    xs = np.round(np.sort(rng.uniform(0, 360, n)), 4)
    runs = ["run1 (ccw)", "run2 (cw)"][: int(rng.integers(1, 3))]
    effects = ["backlash", "cyclic_error", "thermal_drift"][: int(rng.integers(1, 4))]
    steps, amp = [], 10 ** rng.uniform(-1, 1)
    for k in range(len(effects) + 1):
        curves = [np.round(amp * (0.3 ** k) * rng.normal(size=n), 4) for _ in runs]
        steps.append({"label": "base model" if k == 0 else "+ " + effects[k - 1],
                      "residual_um": [c.tolist() for c in curves]})
    ex = {"model": "dbb", "baseline": {"rms_um": 1.0, "heldout_rms_um": 1.1},
          "findings": [{"effect": e, "rms_um_after": 0.5, "heldout_rms_um_after": 0.6} for e in effects],
          "final": {"rms_um": 0.5}, "unexplained": False,
          "residuals": {"domain": "angle_deg", "x": xs.tolist(), "runs": runs, "steps": steps}}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "explain.json")
        with open(path, "w") as f:
            json.dump(ex, f)
        html = subprocess.run([TOOL, "report", path], capture_output=True, text=True, check=True).stdout
    panels = [ET.fromstring(m) for m in re.findall(r'<svg [^>]*data-plot="line".*?</svg>', html, re.S)]
    if len(panels) != len(steps):
        fail("explain %d: %d residual panels for %d steps" % (trial, len(panels), len(steps)))
        continue
    yticks = set()
    for k, (root, step) in enumerate(zip(panels, steps)):
        title = root.find("s:title", NS).text
        want = "Residual of the base model" if k == 0 else "Residual after %s (finding %d)" % (step["label"].replace("_", " "), k)
        if not title.startswith(want):
            fail("explain %d: panel %d titled %r, expected %r" % (trial, k, title, want))
        bx, by = axis_map(root, "x")[1], axis_map(root, "y")[1]
        yticks.add(tuple(axis_map(root, "y")[0]))
        paths = {p.get("data-series"): p for p in find_class(root, "path", "data")}
        if sorted(paths) != sorted(runs):
            fail("explain %d: panel %d draws %s, expected %s" % (trial, k, sorted(paths), runs))
            continue
        for run, curve in zip(runs, step["residual_um"]):
            pts = np.array(path_points(paths[run].get("d")))
            if len(pts) != n:
                fail("explain %d: panel %d run %s: %d points for %d" % (trial, k, run, len(pts), n))
                continue
            xr, yr = (pts[:, 0] - bx[0]) / bx[1], (pts[:, 1] - by[0]) / by[1]
            if np.abs(xr - xs).max() > 0.08 / abs(bx[1]) or np.abs(yr - curve).max() > 0.08 / abs(by[1]):
                fail("explain %d: panel %d run %s: the curve read back differs" % (trial, k, run))
    if len(yticks) != 1:
        fail("explain %d: the panels are not on one y scale: %s" % (trial, yticks))

print("failures:", failures)
sys.exit(1 if failures else 0)
