#!/usr/bin/python3
"""Independent reference for models/common/least_squares: weighted linear least squares with numpy/scipy.

usage: dbb_lsq_oracle.py IN.csv OUT.txt
IN.csv rows: w, y, J_1..J_m. OUT.txt: "rank R", "rms V", "cond C", then per parameter "x u" (full rank only).
"""
import sys

import numpy as np
import scipy.linalg


def main():
    data = np.loadtxt(sys.argv[1], delimiter=",", ndmin=2)
    w, y, jac = data[:, 0], data[:, 1], data[:, 2:]
    sw = np.sqrt(w)
    a = jac * sw[:, None]
    b = y * sw
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    s = np.linalg.svd(a / scale, compute_uv=False)
    rank = int(np.sum(s > 1e-9 * s[0]))
    cond = s[0] / s[-1] if s[-1] > 0 else float("inf")
    x, *_ = scipy.linalg.lstsq(a / scale, b, cond=1e-9, lapack_driver="gelsd")
    x = x / scale
    r = y - jac @ x
    n, m = jac.shape
    with open(sys.argv[2], "w") as out:
        out.write(f"rank {rank}\nrms {np.sqrt(np.mean(r * r)):.17g}\ncond {cond:.17g}\n")
        if rank == m:
            s2 = np.sum(w * r * r) / (n - m)
            cov = s2 * np.linalg.inv(a.T @ a)
            for xi, ui in zip(x, np.sqrt(np.diag(cov))):
                out.write(f"{xi:.17g} {ui:.17g}\n")


if __name__ == "__main__":
    main()
