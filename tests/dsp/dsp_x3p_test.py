#!/usr/bin/python3
"""Real signal: profiles of the X3P scan tests/data/x3p/sample-land.x3p (Sensofar S neox, 918 x 256 float64
heights in metres; provenance in tests/data/README.md) through the dsp library.

    dsp_x3p_test.py PATH/TO/dsp_reference_tool PATH/TO/sample-land.x3p

Every row (a 918-sample profile along X) has masked (NaN) points, so each row's longest finite run is used
(at least 64 samples; about 250 profiles). For db1, db4, db8, db12, db20 in every mode at 5 levels and at the
maximum level: waverec(wavedec(x)) == x to 1e-12 relative (max|rec - x| <= 1e-12 max|x|), and the MRA components
sum to x to the same tolerance. The zip member is read with Python's zipfile (the C++ X3P importer is tested
elsewhere).
"""
import json
import os
import subprocess
import sys
import tempfile
import zipfile

import numpy as np
import pywt

TOL = 1e-12


def longest_finite_run(row):
    best, start = (0, 0), None
    for i, v in enumerate(np.append(row, np.nan)):
        if np.isfinite(v):
            start = i if start is None else start
        elif start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return row[best[0]:best[1]]


def main():
    tool, x3p = sys.argv[1], sys.argv[2]
    with zipfile.ZipFile(x3p) as z:
        name = next(n for n in z.namelist() if n.endswith("bindata/data.bin") and "__MACOSX" not in n)
        data = np.frombuffer(z.read(name), dtype="<f8").reshape(256, 918)
    profiles = [p for p in (longest_finite_run(r) for r in data) if len(p) >= 64]
    assert len(profiles) > 100, f"only {len(profiles)} usable profiles"
    cases = []
    for i, x in enumerate(profiles):
        wname = ["db1", "db4", "db8", "db12", "db20"][i % 5]
        mode = ["zero", "constant", "symmetric", "periodic", "reflect", "periodization"][i % 6]
        maxlev = pywt.dwt_max_level(len(x), pywt.Wavelet(wname).dec_len)
        for level in sorted({min(5, maxlev), maxlev}):
            if level >= 1:
                cases.append({"op": "roundtrip", "wavelet": wname, "mode": mode, "level": level, "x": x.tolist()})
    with tempfile.TemporaryDirectory() as tmp:
        cpath, rpath = os.path.join(tmp, "cases.json"), os.path.join(tmp, "results.json")
        with open(cpath, "w") as f:
            json.dump(cases, f)
        subprocess.run([tool, cpath, rpath], check=True)
        with open(rpath) as f:
            results = json.load(f)
    failures, worst_rec, worst_sum = 0, 0.0, 0.0
    for c, r in zip(cases, results):
        what = f"{c['wavelet']} {c['mode']} level {c['level']} N={len(c['x'])}"
        if "error" in r:
            failures += 1
            print(f"FAIL {what}: {r['error']}")
            continue
        x = np.asarray(c["x"])
        scale = np.max(np.abs(x))
        e_rec = np.max(np.abs(np.asarray(r["rec"]) - x)) / scale
        e_sum = np.max(np.abs(np.asarray(r["mra_sum"]) - x)) / scale
        worst_rec, worst_sum = max(worst_rec, e_rec), max(worst_sum, e_sum)
        if not (e_rec <= TOL and e_sum <= TOL):
            failures += 1
            print(f"FAIL {what}: reconstruction {e_rec:.3g}, MRA sum {e_sum:.3g} (tolerance {TOL})")
    print(f"{len(profiles)} profiles, {len(cases)} cases, {failures} failures; worst relative error: "
          f"reconstruction {worst_rec:.3g}, MRA sum {worst_sum:.3g} (tolerance {TOL})")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
