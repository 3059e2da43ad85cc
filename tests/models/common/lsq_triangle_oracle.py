#!/usr/bin/python3
"""Independent reference for models/common/householder_triangle: the R factor of [sqrt(w) A, sqrt(w) y]
by LAPACK's dgeqrf (numpy.linalg.qr, mode "r"), rows normalised to a positive diagonal.

usage: lsq_triangle_oracle.py IN.csv OUT.txt
IN.csv rows: w, y, A_1..A_m. OUT.txt: the (m+1) x (m+1) triangle, one row per line.
"""
import sys

import numpy as np


def main():
    data = np.loadtxt(sys.argv[1], delimiter=",", ndmin=2)
    w, y, a = data[:, 0], data[:, 1], data[:, 2:]
    sw = np.sqrt(np.maximum(w, 0.0))
    r = np.linalg.qr(np.column_stack([a, y]) * sw[:, None], mode="r")
    r = r * np.where(np.diag(r) < 0, -1.0, 1.0)[:, None]
    np.savetxt(sys.argv[2], r, fmt="%.17g")


if __name__ == "__main__":
    main()
