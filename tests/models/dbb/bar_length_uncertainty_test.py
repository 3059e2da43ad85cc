#!/usr/bin/python3
"""The bar's calibrated length in the DBB uncertainties (docs/conventions.md, "The bar's calibrated
length"), against computations made here with numpy, independently of the identification's code:

- offline: two in-plane (h = 0) circles of the virtual machine, r = 100 mm, ccw and cw, identified with and
  without `--bar-length-u-um`. An error dL0 of the bar's length is the same offset in every reading; with
  h = 0 the two scale columns add up to r for every angle, so the fit puts dL0 / r into each absolute scale
  and nothing elsewhere. Expected here: u(scale_x_ppm) = hypot(u0, 1e6 u_L / r), u(S_x) = hypot(u0, u_L / r),
  the scale mismatch and the centre offsets unchanged; and the runs shifted by 1 um (numpy) move the
  scales by 1 um / r, the rest not.
- through `guideway replay`: the golden DBB recording with the instrument_* header keys (as the daemon
  writes them) gives a PARAMS with the instrument and, for Lai's S_x (patterns with h > 0, where dL0 / r is
  not exact), u = hypot(u0, s u_L) with the sensitivity s measured here by replaying the recording with
  its bar channel shifted by 1 um.

usage: bar_length_uncertainty_test.py BUILD_DIR SOURCE_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

BUILD, SOURCE = sys.argv[1], sys.argv[2]
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
MACHINE = os.path.join(SOURCE, "config", "machine-example.toml")
GOLDEN = os.path.join(SOURCE, "tests", "golden", "dbb.csv")
U_L_UM = 0.8


def run(*args):
    out = subprocess.run([GUIDEWAY, *args], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, f"guideway {' '.join(args)}: {out.stderr}"
    return out.stdout


def identify(files, *extra):
    j = json.loads(run("identify", "dbb", *files, "--json", *extra))
    return {**{k: v for k, v in j["diagnostics"].items()}, **{"lai3." + k: v for k, v in j["lai3"].items()}}, j


def shifted_run(path, out, shift_um):
    """The run file with every dL moved by shift_um (numpy does the arithmetic; the header is kept)."""
    with open(path) as f:
        lines = f.read().splitlines()
    first = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    data = np.loadtxt(lines[first + 1:], delimiter=",", ndmin=2)
    data[:, 2] += shift_um
    with open(out, "w") as f:
        f.write("\n".join(lines[:first + 1]) + "\n")
        for row in data:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def close(a, b, rel, what):
    assert np.isclose(a, b, rtol=rel, atol=0), f"{what}: {a!r}, expected {b!r}"


def offline(d):
    files, shifted = [], []
    for i, direction in enumerate(("ccw", "cw")):
        path = os.path.join(d, f"{direction}.csv")
        run("simulate", "dbb", "--machine", MACHINE, "--radius-mm", "100", "--height-mm", "0", "--direction",
            direction, "--seed", str(20 + i), "--out", path)
        files.append(path)
        shifted.append(os.path.join(d, f"{direction}.shifted.csv"))
        shifted_run(path, shifted[-1], 1.0)
    r_m = 0.100
    base, _ = identify(files)
    with_u, j = identify(files, "--bar-length-u-um", str(U_L_UM))
    moved, _ = identify(shifted)
    for name in ("scale_x_ppm", "scale_y_ppm"):
        close(with_u[name]["u"], np.hypot(base[name]["u"], 1e6 * U_L_UM * 1e-6 / r_m), 1e-6, "u(" + name + ")")
        close(with_u[name]["value"], base[name]["value"], 1e-12, name + " value")
        close(moved[name]["value"] - base[name]["value"], 1e6 * 1e-6 / r_m, 1e-3, name + " moved by 1 um / r")
    for name in ("lai3.S_x", "lai3.S_y"):
        close(with_u[name]["u"], np.hypot(base[name]["u"], U_L_UM * 1e-6 / r_m), 1e-6, "u(" + name + ")")
        close(moved[name]["value"] - base[name]["value"], 1e-6 / r_m, 1e-3, name + " moved by 1 um / r")
    for name in ("scale_mismatch_ppm", "run1.center_offset_x_um", "squareness_urad", "backlash_x_um", "lai3.e_x_um"):
        close(with_u[name]["u"], base[name]["u"], 1e-6, "u(" + name + ") unchanged")
        assert abs(moved[name]["value"] - base[name]["value"]) < 1e-3 * max(base[name]["u"], 1e-9) + 1e-9, name
    assert any("bar's calibrated length" in n for n in j["notes"]), j["notes"]
    print(f"offline: u(scale_x_ppm) {base['scale_x_ppm']['u']:.4g} -> {with_u['scale_x_ppm']['u']:.4g} ppm "
          f"(1e6 u_L / r = {1e6 * U_L_UM * 1e-6 / r_m:.4g}); u(S_x) {base['lai3.S_x']['u']:.4g} -> "
          f"{with_u['lai3.S_x']['u']:.4g}")


def params_of(path):
    out = run("replay", "--json", path)
    return next(m for m in map(json.loads, out.splitlines()) if m["class"] == "PARAMS")


def replayed(d):
    with open(GOLDEN) as f:
        lines = f.read().splitlines(keepends=True)
    first = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    keys = ["# instrument_serial = 1001\n", "# instrument_calibration_certificate = C-2023-117\n",
            "# instrument_calibrated_on = 2023-01-10\n", "# instrument_calibration_due = 2024-01-10\n",
            "# instrument_calibrated_length_mm = 100\n", f"# instrument_calibrated_length_u_um = {U_L_UM}\n"]
    calibrated = os.path.join(d, "calibrated.csv")
    with open(calibrated, "w") as f:
        f.writelines(lines[:first] + keys + lines[first:])
    # The bar channel shifted by 1 um (the same recording otherwise), to measure the sensitivity.
    header = lines[first].strip().split(",")
    bar = header.index("bar_length_m")
    shifted = os.path.join(d, "shifted.csv")
    with open(shifted, "w") as f:
        f.writelines(lines[:first + 1])
        for l in lines[first + 1:]:
            if l.startswith("#"):
                f.write(l)
                continue
            cells = l.rstrip("\n").split(",")
            cells[bar] = repr(float(np.float64(cells[bar]) + 1e-6))
            f.write(",".join(cells) + "\n")
    base, cal, moved = params_of(GOLDEN), params_of(calibrated), params_of(shifted)
    assert "instrument" not in base, "the golden recording names no instrument"
    inst = cal["instrument"]
    assert inst["serial"] == "1001" and inst["calibration_due"] == "2024-01-10", inst
    assert inst["calibrated_length_u_um"] == U_L_UM and inst["calibrated_length_mm"] == 100, inst
    assert inst["checked_on"] == "2026-11-25" and inst["calibration_expired"] is True, inst  # started_utc's date
    s = (moved["lai3"]["S_x"]["value"] - base["lai3"]["S_x"]["value"]) / 1.0  # per um
    expected = np.hypot(base["lai3"]["S_x"]["u"], s * U_L_UM)
    close(cal["lai3"]["S_x"]["u"], expected, 1e-3, "u(S_x) of the replay")
    close(cal["lai3"]["S_x"]["value"], base["lai3"]["S_x"]["value"], 1e-12, "S_x value")
    print(f"replay: dS_x/dL0 = {s:.6g} per um (1/L = {1e-6 / 0.1:.5g}); u(S_x) {base['lai3']['S_x']['u']:.4g} -> "
          f"{cal['lai3']['S_x']['u']:.4g} (numpy: {expected:.4g})")


def main():
    with tempfile.TemporaryDirectory(prefix="gwbl-") as d:
        offline(d)
        replayed(d)
    print("ok")


if __name__ == "__main__":
    main()
