#!/usr/bin/python3
"""Reference test of guideway's dsp library against PyWavelets 1.1.1 and numpy (Debian, /usr/bin/python3).

    dsp_reference_test.py PATH/TO/dsp_reference_tool [--quick]

Cases: every wavelet (db1..db20, sym2..sym20, coif1..coif5) x every mode (zero, constant, symmetric, periodic,
reflect, periodization) x signal lengths 1, 2, 3, 5, 8, 13, 32, 67, 100 x every level 0..dwt_max_level (+1 beyond
for the short ones): wavedec, waverec (of PyWavelets' coefficients), MRA (reference: waverec with every other
band zeroed, first N samples) and single-level dwt/idwt; long signals (4096, 10007) for a few wavelets; the
streaming cascade against pywt zero mode; denoising against a numpy implementation of the same rule;
Pearson and normalised cross-correlation against numpy.

Tolerance (stated): for every band/output, max|ours - ref| <= 1e-10 * max(max|ref|, max|input|, 1e-300),
i.e. 1e-10 relative to the scale of the data. Lengths must be equal exactly.
(mode reflect with N = 1 is skipped: PyWavelets 1.1.1 never returns on it.)
"""
import json
import os
import subprocess
import sys
import tempfile

import warnings

import numpy as np
import pywt

warnings.simplefilter("ignore", UserWarning)  # PyWavelets warns for levels above dwt_max_level

TOL = 1e-10
WAVELETS = [f"db{i}" for i in range(1, 21)] + [f"sym{i}" for i in range(2, 21)] + [f"coif{i}" for i in range(1, 6)]
MODES = ["zero", "constant", "symmetric", "periodic", "reflect", "periodization"]


def reflect_hits_one(n, flen, level):
    """True when a level of the decomposition would transform a single sample (PyWavelets hangs in reflect)."""
    for _ in range(level):
        if n == 1:
            return True
        n = (n + flen - 1) // 2
    return False


def main():
    tool = sys.argv[1]
    quick = "--quick" in sys.argv
    rng = np.random.default_rng(20240611)
    cases, checks = [], []

    def add(case, check):
        cases.append(case)
        checks.append(check)

    lengths = [1, 2, 3, 5, 8, 13, 32, 67, 100]
    wavelets = WAVELETS if not quick else ["db1", "db4", "sym5", "coif2"]
    for wname in wavelets:
        w = pywt.Wavelet(wname)
        for mode in MODES:
            for n in lengths:
                if mode == "reflect" and n == 1:
                    continue
                x = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 3)
                maxlev = pywt.dwt_max_level(n, w.dec_len)
                levels = list(range(0, maxlev + 1)) + ([maxlev + 1] if n <= 5 else [])
                for level in levels:
                    if mode == "reflect" and reflect_hits_one(n, w.dec_len, level):
                        continue
                    ref = pywt.wavedec(x, w, mode=mode, level=level)
                    add({"op": "wavedec", "wavelet": wname, "mode": mode, "level": level, "x": x.tolist()},
                        ("bands", ref, x, f"wavedec {wname} {mode} N={n} level={level}"))
                    if level >= 1:
                        rec = pywt.waverec(ref, w, mode=mode)
                        add({"op": "waverec", "wavelet": wname, "mode": mode, "coeffs": [c.tolist() for c in ref]},
                            ("array", rec, x, f"waverec {wname} {mode} N={n} level={level}"))
                    if level >= 1 and (n in (1, 2, 13, 67) or level == maxlev):
                        comps = []
                        for b in range(len(ref)):
                            z = [c if i == b else np.zeros_like(c) for i, c in enumerate(ref)]
                            comps.append(pywt.waverec(z, w, mode=mode)[:n])
                        add({"op": "mra", "wavelet": wname, "mode": mode, "level": level, "x": x.tolist()},
                            ("mra", comps, x, f"mra {wname} {mode} N={n} level={level}"))
                # one level, and idwt of random coefficients
                a, d = pywt.dwt(x, w, mode=mode)
                add({"op": "dwt", "wavelet": wname, "mode": mode, "x": x.tolist()},
                    ("bands", [a, d], x, f"dwt {wname} {mode} N={n}"))
                ca, cd = rng.standard_normal(len(a)), rng.standard_normal(len(a))
                add({"op": "idwt", "wavelet": wname, "mode": mode, "a": ca.tolist(), "d": cd.tolist()},
                    ("array", pywt.idwt(ca, cd, w, mode=mode), ca, f"idwt {wname} {mode} n={len(a)}"))

    # long signals
    for wname in ["db1", "db4", "db8", "db20", "sym8", "coif5"]:
        for mode in MODES:
            for n in ([4096, 10007] if not quick else [10007]):
                x = np.cumsum(rng.standard_normal(n)) + 1e3
                level = pywt.dwt_max_level(n, pywt.Wavelet(wname).dec_len)
                ref = pywt.wavedec(x, wname, mode=mode, level=level)
                add({"op": "wavedec", "wavelet": wname, "mode": mode, "level": level, "x": x.tolist()},
                    ("bands", ref, x, f"wavedec {wname} {mode} N={n} level={level}"))
                add({"op": "waverec", "wavelet": wname, "mode": mode, "coeffs": [c.tolist() for c in ref]},
                    ("array", pywt.waverec(ref, wname, mode=mode), x, f"waverec {wname} {mode} N={n}"))
                if n == 10007 and wname in ("db1", "db4", "coif5"):
                    lv = min(level, 5)
                    r5 = pywt.wavedec(x, wname, mode=mode, level=lv)
                    comps = []
                    for b in range(len(r5)):
                        z = [c if i == b else np.zeros_like(c) for i, c in enumerate(r5)]
                        comps.append(pywt.waverec(z, wname, mode=mode)[:n])
                    add({"op": "mra", "wavelet": wname, "mode": mode, "level": lv, "x": x.tolist()},
                        ("mra", comps, x, f"mra {wname} {mode} N={n} level={lv}"))

    # streaming cascade == pywt zero mode (after flush), random chunkings
    for wname in ["db1", "db2", "db4", "db8", "sym5", "coif3", "db20"]:
        for n, level in [(1, 1), (2, 2), (77, 3), (1000, 5), (3001, 4)]:
            x = rng.standard_normal(n)
            ref = pywt.wavedec(x, wname, mode="zero", level=level)
            chunks = [int(c) for c in rng.integers(1, 50, size=7)]
            add({"op": "stream", "wavelet": wname, "level": level, "x": x.tolist(), "chunks": chunks},
                ("bands", ref, x, f"stream {wname} N={n} level={level} chunks={chunks}"))

    # denoising: numpy implementation of the documented rule
    for wname, mode, rule, ld in [("db4", "symmetric", "soft", False), ("db8", "periodization", "hard", False),
                                  ("sym6", "zero", "soft", True), ("db1", "reflect", "hard", True)]:
        n = 2000
        t = np.linspace(0, 1, n)
        x = np.sin(2 * np.pi * 3 * t) + 0.1 * rng.standard_normal(n)
        level = 5
        c = pywt.wavedec(x, wname, mode=mode, level=level)
        sig = np.median(np.abs(c[-1])) / 0.6745
        out = [c[0]]
        for d in c[1:]:
            s = np.median(np.abs(d)) / 0.6745 if ld else sig
            lam = s * np.sqrt(2 * np.log(n))
            out.append(pywt.threshold(d, lam, mode=rule))
        ref = pywt.waverec(out, wname, mode=mode)[:n]
        add({"op": "denoise", "wavelet": wname, "mode": mode, "level": level, "rule": rule, "level_dependent": ld,
             "x": x.tolist()}, ("denoise", ref, x, f"denoise {wname} {mode} {rule} level_dependent={ld}"))

    # correlation
    for n, max_lag in [(2, 1), (10, 3), (500, 40), (1001, 1000)]:
        x = rng.standard_normal(n)
        y = 0.5 * np.roll(x, 3) + rng.standard_normal(n) * 0.3 + 7.0
        add({"op": "pearson", "x": x.tolist(), "y": y.tolist()},
            ("scalar", np.corrcoef(x, y)[0, 1], None, f"pearson N={n}"))
        xm, ym = x - x.mean(), y - y.mean()
        full = np.correlate(ym, xm, "full") / np.sqrt(np.sum(xm * xm) * np.sum(ym * ym))
        k = min(max_lag, n - 1)
        ref = full[n - 1 - k:n + k]
        add({"op": "xcorr", "x": x.tolist(), "y": y.tolist(), "max_lag": max_lag},
            ("xcorr", ref, k, f"xcorr N={n} max_lag={max_lag}"))
    add({"op": "pearson", "x": [1.0, 1.0, 1.0], "y": [1.0, 2.0, 3.0]}, ("error", "constant", None, "pearson constant"))
    add({"op": "pearson", "x": [1.0, 5.0, 1.0], "nan_at": 1, "y": [1.0, 2.0, 3.0]}, ("error", "finite", None, "pearson NaN"))
    add({"op": "pearson", "x": [1.0, 2.0], "y": [1.0, 2.0, 3.0]}, ("error", "unequal", None, "pearson lengths"))

    with tempfile.TemporaryDirectory() as tmp:
        cpath, rpath = os.path.join(tmp, "cases.json"), os.path.join(tmp, "results.json")
        with open(cpath, "w") as f:
            json.dump(cases, f, allow_nan=True)
        if os.environ.get("DSP_KEEP_CASES"):
            import shutil
            shutil.copy(cpath, os.environ["DSP_KEEP_CASES"])
        subprocess.run([tool, cpath, rpath], check=True)
        with open(rpath) as f:
            results = json.load(f)

    failures = 0
    worst = 0.0

    def close(ours, ref, scale_from, what):
        nonlocal failures, worst
        ours = np.asarray(ours, dtype=float)
        ref = np.asarray(ref, dtype=float)
        if ours.shape != ref.shape:
            failures += 1
            print(f"FAIL {what}: length {ours.shape} != reference {ref.shape}")
            return
        if ref.size == 0:
            return
        scale = max(np.max(np.abs(ref)), np.max(np.abs(scale_from)) if scale_from is not None else 0.0, 1e-300)
        err = np.max(np.abs(ours - ref)) / scale
        worst = max(worst, err)
        if not err <= TOL:
            failures += 1
            print(f"FAIL {what}: relative error {err:.3g} > {TOL}")

    for res, (kind, ref, x, what) in zip(results, checks):
        if kind == "error":
            if "error" not in res or ref not in res["error"]:
                failures += 1
                print(f"FAIL {what}: expected an error mentioning '{ref}', got {res}")
            continue
        if "error" in res:
            failures += 1
            print(f"FAIL {what}: error {res['error']}")
            continue
        if kind == "bands":
            if len(res["coeffs"]) != len(ref):
                failures += 1
                print(f"FAIL {what}: {len(res['coeffs'])} bands, reference {len(ref)}")
                continue
            for b, (o, r) in enumerate(zip(res["coeffs"], ref)):
                close(o, r, x, f"{what} band {b}")
        elif kind == "array":
            close(res["x"], ref, x, what)
        elif kind == "mra":
            for b, (o, r) in enumerate(zip(res["components"], ref)):
                close(o, r, x, f"{what} component {b}")
            close(np.sum(res["components"], axis=0), x, x, f"{what} sum of components")
        elif kind == "denoise":
            close(res["x"], ref, x, what)
        elif kind == "scalar":
            close([res["value"]], [ref], None, what)
        elif kind == "xcorr":
            close(res["values"], ref, None, what)
            peak = int(np.argmax(ref)) - x
            if res["peak_lag"] != peak or abs(res["peak_value"] - ref.max()) > TOL:
                failures += 1
                print(f"FAIL {what}: peak ({res['peak_lag']}, {res['peak_value']}) != ({peak}, {ref.max()})")
    print(f"{len(cases)} cases, {failures} failures, worst relative error {worst:.3g} (tolerance {TOL})")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
