#!/usr/bin/python3
"""`guideway wavelet wavedec|mra|denoise` and `guideway correlate` end to end, against PyWavelets/numpy.

    dsp_cli_test.py PATH/TO/guideway

Tolerance: 1e-10 relative to the data scale (as dsp_reference_test.py). Also checks the input formats (CSV with
metadata and header, one number per line) and that bad input gives an error naming file and line.
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import pywt

TOL = 1e-10


def run(*args, ok=True):
    p = subprocess.run(list(args), capture_output=True, text=True)
    if ok and p.returncode != 0:
        raise AssertionError(f"{args} failed: {p.stderr}")
    if not ok and p.returncode == 0:
        raise AssertionError(f"{args} should have failed")
    return p


def close(ours, ref, scale, what):
    ours, ref = np.asarray(ours, dtype=float), np.asarray(ref, dtype=float)
    assert ours.shape == ref.shape, f"{what}: shape {ours.shape} != {ref.shape}"
    err = np.max(np.abs(ours - ref)) / scale if ref.size else 0.0
    assert err <= TOL, f"{what}: relative error {err:.3g}"


def read_table(path):
    """Rows of numbers of a Guideway CSV: '#' lines and the header row skipped."""
    lines = [ln for ln in open(path).read().splitlines() if ln and not ln.startswith("#")]
    return np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


def main():
    gw = sys.argv[1]
    rng = np.random.default_rng(5)
    with tempfile.TemporaryDirectory() as tmp:
        n = 1001
        t = np.arange(n) * 1e-3
        z = 1e-6 * (np.sin(2 * np.pi * 3 * t) + 0.1 * rng.standard_normal(n))
        csv = os.path.join(tmp, "profile.csv")
        with open(csv, "w") as f:
            f.write("# format = guideway/profile/1\n# device = pgi\n")
            f.write("x_m,z_m\n")
            for a, b in zip(t, z):
                f.write(f"{a!r},{b!r}\n")
            f.write("# end = complete\n")
        plain = os.path.join(tmp, "plain.txt")
        np.savetxt(plain, z, fmt="%.17g")

        for wname, mode, level in [("db4", "periodization", 5), ("db1", "symmetric", 3), ("sym8", "zero", None)]:
            args = [gw, "wavelet", "wavedec", "--wavelet", wname, "--mode", mode, "--column", "z_m", csv]
            if level is not None:
                args[3:3] = ["--level", str(level)]
            j = json.loads(run(*args).stdout)
            ref = pywt.wavedec(z, wname, mode=mode, level=level)
            assert j["wavelet"] == wname and j["mode"] == mode and j["level"] == len(ref) - 1, j
            assert len(j["coeffs"]) == len(ref)
            for b, (o, r) in enumerate(zip(j["coeffs"], ref)):
                close(o, r, np.abs(z).max(), f"wavedec {wname} {mode} band {b}")
        # one number per line, no --column needed
        j = json.loads(run(gw, "wavelet", "wavedec", "--wavelet", "db2", "--level", "2", plain).stdout)
        for o, r in zip(j["coeffs"], pywt.wavedec(z, "db2", mode="symmetric", level=2)):
            close(o, r, np.abs(z).max(), "wavedec plain file")

        # mra: reference = waverec with the other bands zeroed
        out_csv = os.path.join(tmp, "mra.csv")
        j = json.loads(run(gw, "wavelet", "mra", "--wavelet", "db1", "--level", "5", "--column", "z_m", csv,
                           "--out", out_csv).stdout)
        c = pywt.wavedec(z, "db1", mode="symmetric", level=5)
        for b in range(len(c)):
            zc = [ci if i == b else np.zeros_like(ci) for i, ci in enumerate(c)]
            close(j["components"][b], pywt.waverec(zc, "db1", mode="symmetric")[:n], np.abs(z).max(), f"mra {b}")
        assert j["bands"] == ["a5", "d5", "d4", "d3", "d2", "d1"]
        table = read_table(out_csv)
        close(table.sum(axis=1), z, np.abs(z).max(), "mra csv sums to the signal")

        # denoise: the documented rule, in numpy
        den = os.path.join(tmp, "den.csv")
        run(gw, "wavelet", "denoise", "--wavelet", "db8", "--level", "4", "--mode", "periodization", "--rule", "hard",
            "--column", "z_m", csv, "--out", den)
        ours = read_table(den)[:, 0]
        c = pywt.wavedec(z, "db8", mode="periodization", level=4)
        lam = np.median(np.abs(c[-1])) / 0.6745 * np.sqrt(2 * np.log(n))
        ref = pywt.waverec([c[0]] + [pywt.threshold(d, lam, mode="hard") for d in c[1:]], "db8",
                           mode="periodization")[:n]
        close(ours, ref, np.abs(z).max(), "denoise --out")
        stdout_values = np.array([float(v) for v in run(gw, "wavelet", "denoise", "--wavelet", "db8", "--level", "4",
                                                         "--mode", "periodization", "--rule", "hard", plain)
                                  .stdout.split()])
        close(stdout_values, ref, np.abs(z).max(), "denoise to stdout")

        # correlate: pearson and the cross-correlation peak of a delayed copy
        y = np.roll(z, 7) + 1e-8 * rng.standard_normal(n)
        other = os.path.join(tmp, "other.txt")
        np.savetxt(other, y, fmt="%.17g")
        j = json.loads(run(gw, "correlate", plain, other, "--max-lag", "20").stdout)
        close([j["pearson"]], [np.corrcoef(z, y)[0, 1]], 1.0, "pearson")
        assert j["peak"]["lag"] == 7, j

        # errors name the file and the line
        bad = os.path.join(tmp, "bad.csv")
        with open(bad, "w") as f:
            f.write("# a = 1\nz_m\n1.0\n2.0\nabc\n")
        p = run(gw, "wavelet", "wavedec", bad, ok=False)
        assert f"{bad}:5:" in p.stderr and "abc" in p.stderr, p.stderr
        p = run(gw, "wavelet", "wavedec", csv, ok=False)
        assert "choose one with --column" in p.stderr, p.stderr
        const = os.path.join(tmp, "const.txt")
        np.savetxt(const, np.full(n, 0.1))
        p = run(gw, "correlate", const, plain, ok=False)
        assert "constant" in p.stderr, p.stderr
        short = os.path.join(tmp, "short.txt")
        np.savetxt(short, np.ones(10))
        p = run(gw, "correlate", short, plain, ok=False)
        assert "equally long" in p.stderr, p.stderr
    print("guideway wavelet/correlate: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
