#!/usr/bin/python3
"""Independent read of an X3P file (zipfile + ElementTree + numpy) for x3p_profile_files_test.

Prints `key value` lines: sizes, increments, the data type, NaN count, per-row nanmean of a few rows,
and z at a few (ix, iy) positions, as repr() so the C++ test can compare exactly.
"""
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np

path = sys.argv[1]
with zipfile.ZipFile(path) as z:
    main = min((n for n in z.namelist() if n.endswith("main.xml") and not n.startswith("__MACOSX")), key=len)
    base = main[: -len("main.xml")]
    root = ET.fromstring(z.read(main))
    r1, r3 = root.find("Record1"), root.find("Record3")
    sx = int(r3.find("MatrixDimension/SizeX").text)
    sy = int(r3.find("MatrixDimension/SizeY").text)
    dtype = r1.find("Axes/CZ/DataType").text
    link = r3.find("DataLink/PointDataLink").text
    raw = z.read(base + link)
np_type = {"D": "<f8", "F": "<f4", "L": "<i4", "I": "<i2"}[dtype]
z = np.frombuffer(raw, dtype=np_type)[: sx * sy].astype(np.float64).reshape(sy, sx)  # x fastest
print("size_x", sx)
print("size_y", sy)
print("increment_x", repr(float(r1.find("Axes/CX/Increment").text)))
print("increment_y", repr(float(r1.find("Axes/CY/Increment").text)))
print("data_type", dtype)
print("nan_count", int(np.isnan(z).sum()))
for iy in (0, 100, sy - 1):
    print("row_nanmean", iy, repr(float(np.nanmean(z[iy]))) if not np.all(np.isnan(z[iy])) else "nan")
for ix, iy in ((0, 0), (459, 128), (917, 255), (100, 37), (800, 200)):
    if ix < sx and iy < sy:
        print("z", ix, iy, repr(float(z[iy, ix])))
