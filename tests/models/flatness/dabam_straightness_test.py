#!/usr/bin/python3
"""`guideway identify straightness` on every real DABAM slope profile in tests/data/dabam, against numpy.

Usage: dabam_straightness_test.py GUIDEWAY_BINARY DABAM_DIR

The oracle reads each entry as the database's own reader does (numpy.loadtxt after FILE_HEADER_LINES, the
metadata's column indices and factors) and integrates it independently as a traverse: a reading's feet half
the median spacing either side of its position, each reading's own spacing as measured, heights the
cumulative sum of spacing x slope; the least-squares line by numpy.polyfit, the end-point line through the
first and last station. Checked, for every entry (tilted flats and curved mirrors included):
- accepted with no option, instrument "deflectometer" (the database's), the readings' middle and span;
- end-point and least-squares straightness equal numpy's to 1e-9 relative;
- positions that jitter (dabam-901: x rounded to 1 um) accepted, the jitter stated as numpy finds it;
- the readings' scatter equals PyWavelets' (db4, periodization, MAD of the finest details), and the note
  on u is there exactly when it and the instrument's u differ by more than 3x;
- no selection bias is negative; the u from the data is reported beside the instrument's.
And the refusals, and the acceptances, that named instruments and explicit ranges make right: the TA80's +-600" refuses a curved
mirror naming its extreme readings, --range-arcsec accepts it, the level's +-206"
about the readings' middle takes a 392" span tilted by 171" and refuses a 1,643" one.
"""
import glob
import json
import os
import subprocess
import sys

import numpy as np
import pywt

GUIDEWAY, DABAM = sys.argv[1], sys.argv[2]
ARCSEC = np.pi / 180 / 3600
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def run(*args):
    p = subprocess.run([GUIDEWAY, "identify", "straightness", *args], capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def read_entry(dat):
    meta = json.load(open(dat[:-4] + ".txt"))
    cx = meta.get("COLUMN_INDEX_ABSCISSA", meta.get("COLUMN_INDEX_ABSCISSAS", 0))
    cy = meta.get("COLUMN_INDEX_ORDINATE", meta.get("COLUMN_INDEX_ORDINATES", 1))
    a = np.loadtxt(dat, skiprows=int(meta.get("FILE_HEADER_LINES", 0)), ndmin=2)
    x = a[:, cx] * float(meta["X1_FACTOR"])
    slope = a[:, cy] * float(meta["Y1_FACTOR"])
    order = np.argsort(x)
    return x[order], slope[order]


def numpy_straightness(x, slope):
    step = np.sort(np.diff(x))[(len(x) - 1) // 2]  # the median spacing (the upper one of an even count)
    ds = np.append(np.diff(x), step)
    ds[np.abs(ds - step) <= 1e-9 * step] = step
    stations = np.concatenate([[x[0] - step / 2], x[0] - step / 2 + np.cumsum(ds)])
    h = np.concatenate([[0.0], np.cumsum(ds * slope)])  # tan(atan(slope)) = slope
    ls = h - np.polyval(np.polyfit(stations, h, 1), stations)
    ep = h - (h[0] + (h[-1] - h[0]) * (stations - stations[0]) / (stations[-1] - stations[0]))
    jitter = np.max(np.abs(np.diff(x) - step)) / step
    return {"end_point": np.ptp(ep), "least_squares": np.ptp(ls), "jitter": jitter if jitter > 1e-9 else 0.0}


def pywt_scatter(angle):
    d = pywt.dwt(angle, "db4", mode="periodization")[1][:-3]  # the last 3 wrap round the ends
    return np.median(np.abs(d)) / 0.6745


entries = sorted(glob.glob(os.path.join(DABAM, "dabam-*.dat")))
check(len(entries) == 32, "32 DABAM entries in %s (found %d)" % (DABAM, len(entries)))
worst = {"end_point": 0.0, "least_squares": 0.0}
noted = 0
for dat in entries:
    name = os.path.basename(dat)[:-4]
    rc, out, err = run("--json", dat)
    if rc != 0:
        check(False, "%s accepted with no option (%s)" % (name, err.strip()))
        continue
    j = json.loads(out)
    v = j["vertical"]
    x, slope = read_entry(dat)
    ref = numpy_straightness(x, slope)
    angle = np.arctan(slope)
    ok = j["instrument"]["name"] == "deflectometer" and j["readings"] == len(x)
    for line in ("end_point", "least_squares"):
        rel = abs(v[line]["straightness_um"] * 1e-6 - ref[line]) / ref[line]
        worst[line] = max(worst[line], rel)
        ok &= rel <= 1e-9
    ok &= abs(v["tilt_arcsec"] - (angle.max() + angle.min()) / 2 / ARCSEC) <= 1e-6
    ok &= abs(v["span_arcsec"] - np.ptp(angle) / ARCSEC) <= 1e-6
    ok &= abs(j["jitter_percent"] - 100 * ref["jitter"]) <= 1e-9
    scatter = pywt_scatter(angle)
    ok &= abs(v["u_angle_data_arcsec"] * ARCSEC - scatter) <= 1e-9 * scatter
    ratio = v["u_angle_arcsec"] / v["u_angle_data_arcsec"]
    disagree = ratio > 3 or ratio < 1 / 3
    noted += disagree
    ok &= (v["u_disagreement"] is not None) == disagree
    biases = [v[k]["selection_bias_um"] for k in ("end_point", "least_squares", "minimum_zone")]
    ok &= min(biases) >= 0 and all(v[k]["u_straightness_data_um"] is not None for k in ("end_point", "least_squares"))
    check(ok, "%s: %d readings, span %.1f\", tilt %.1f\", jitter %.3g %%; least squares %.6f um (numpy %.6f), "
          "end-point %.6f um (numpy %.6f); scatter %.3g\" (PyWavelets %.3g\"), instrument u / scatter %.2g; "
          "selection bias >= 0" % (name, j["readings"], v["span_arcsec"], v["tilt_arcsec"], j["jitter_percent"],
                                   v["least_squares"]["straightness_um"], ref["least_squares"] * 1e6,
                                   v["end_point"]["straightness_um"], ref["end_point"] * 1e6,
                                   v["u_angle_data_arcsec"], scatter / ARCSEC, ratio))
print("worst relative difference from numpy: end-point %.2g, least squares %.2g; u note on %d of %d entries"
      % (worst["end_point"], worst["least_squares"], noted, len(entries)))

# Jittered positions: used as measured, said in the text.
rc, out, err = run(os.path.join(DABAM, "dabam-901.dat"))
check(rc == 0 and "positions jitter by up to 0.34 % of it: each reading's own spacing used; tolerance 5 %" in out,
      "dabam-901 (x rounded to 1 um): the jitter stated in the text output")

# The disagreement between the instrument's u and the data's, in the text.
rc, out, err = run(os.path.join(DABAM, "dabam-061.dat"))
check(rc == 0 and "note: the readings scatter" in out and "below the 0.0238\" stated for the deflectometer" in out
      and "from the readings' scatter u" in out, "dabam-061: the note on u and the data's u in the text output")

# Named instruments and ranges: a curved mirror (003, 2,613" span) is out of the TA80's reach, within an
# explicit range; a 392" span (062) is out of the electronic level's +-206".
rc, out, err = run("--instrument", "autocollimator", os.path.join(DABAM, "dabam-003.dat"))
check(rc == 1 and "slope spans 2613.43\"" in err and "more than the autocollimator's range +-600\"" in err
      and "dabam-003.dat:" in err, "dabam-003 with the TA80: refused, the span and the range named (%s)" % err.strip())
rc, out, err = run("--instrument", "autocollimator", "--range-arcsec", "1500", "--json",
                   os.path.join(DABAM, "dabam-003.dat"))
check(rc == 0 and json.loads(out)["instrument"]["range_arcsec"] == 1500
      and abs(json.loads(out)["instrument"]["u_arcsec"] - 0.2887) < 1e-4,
      "dabam-003 with the TA80 and --range-arcsec 1500: accepted, the TA80's u")
rc, out, err = run("--instrument", "level", os.path.join(DABAM, "dabam-062.dat"))
check(rc == 0, "dabam-062 (392\" span, 171\" tilt) with the level: within its +-206\" about the middle")
rc, out, err = run("--instrument", "level", os.path.join(DABAM, "dabam-006.dat"))
check(rc == 1 and "more than the level's range +-206.265\"" in err, "dabam-006 with the level: refused (%s)" % err.strip())
rc, out, err = run("--instrument", "theodolite", os.path.join(DABAM, "dabam-062.dat"))
check(rc != 0 and "unknown instrument 'theodolite' (known: autocollimator, level, deflectometer)" in err,
      "an unknown instrument named with the known ones (%s)" % err.strip())
rc, out, err = run("--angle-u-arcsec", "0.002", "--json", os.path.join(DABAM, "dabam-061.dat"))
check(rc == 0 and json.loads(out)["vertical"]["u_angle_arcsec"] == 0.002
      and json.loads(out)["vertical"]["u_disagreement"] is None, "--angle-u-arcsec overrides the profile's u")

if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
