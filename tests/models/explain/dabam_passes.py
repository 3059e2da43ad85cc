"""Real DABAM flats (tests/data/dabam) as a traverse's forward and return passes, for the EXPLAIN tests
(dabam_explain_cli_test.py, dabam_scenarios_test.py): one way to read an entry and to write its passes."""
import json
import os

import numpy as np

ARCSEC = 180 / np.pi * 3600  # arcsec per rad


def read_entry(dabam, name):
    """An entry's stations (m) and slopes (rad), in increasing x, read as its .txt metadata says."""
    meta = json.load(open(os.path.join(dabam, name + ".txt")))
    a = np.loadtxt(os.path.join(dabam, name + ".dat"), skiprows=int(meta.get("FILE_HEADER_LINES", 0)), ndmin=2)
    order = np.argsort(a[:, 0])
    return a[order, 0] * float(meta["X1_FACTOR"]), a[order, 1] * float(meta["Y1_FACTOR"])


def pitch_wave(x_m, amplitude_rad, cycles=8, phase_rad=0.7):
    """A pitch wave of `cycles` over the stations' span (the passes' length, a station a step), at each station's
    mid-point: amplitude sin(2 pi cycles (x - x0 + step / 2) / span + phase)."""
    n = len(x_m)
    return amplitude_rad * np.sin(2 * np.pi * cycles * (np.arange(n) + 0.5) / n + phase_rad)


def forward_and_return(path, x_m, slope_rad, rocking_rad, seed, settling=0.0, shared_rad=0.0, drift_rad_per_s=0.0,
                       yaw_rad=None, coupling=0.0, chip=None):
    """Two passes over the same stations, 2 s a station: the readings +r forward and -r back, the return with fresh
    noise of 10 % of the slope RMS; with `settling`, the return's first readings settle after the reversal (that many
    slope RMS, decaying over 3 readings); `shared_rad` (a value or one a station) read by both passes, as the
    geometry is (a machine's pitch wave); `drift_rad_per_s`, the instrument's zero drifting with the readings' time;
    `yaw_rad`, a pair (forward, return) of the carriage's yaw at each station as each pass takes it, written as the
    yaw_arcsec column, of which the pitch reads `coupling` (sin r: the head turned r about its beam); `chip`, a pair
    (fraction, tilt_rad): a chip caught under a foot that far into the return pass tilts each later reading of it
    (as ExplainIsoTraverse.AChipUnderAFootIsUnexplainedNotAFinding's). Written in the traverse format
    (docs/formats.md)."""
    n, step, rms = len(x_m), (x_m[-1] - x_m[0]) / (len(x_m) - 1), np.std(slope_rad)
    t_forward, t_back = 2.0 * np.arange(n), 2.0 * (2 * n - 1 - np.arange(n)) + 10
    back = slope_rad + np.random.RandomState(seed).normal(0.0, 0.1 * rms, n) - rocking_rad + shared_rad
    slope_rad = slope_rad + shared_rad
    back[::-1] += settling * rms * np.exp(-np.arange(n) / 3.0)
    if drift_rad_per_s:
        slope_rad, back = slope_rad + drift_rad_per_s * t_forward, back + drift_rad_per_s * t_back
    if coupling:
        slope_rad, back = slope_rad + coupling * yaw_rad[0], back + coupling * yaw_rad[1]
    if chip is not None:
        back[:n - int(chip[0] * n)] += chip[1]  # the return runs from the last station to the first
    yaw = ["", ""] if yaw_rad is None else [[",%.6f" % (v * ARCSEC) for v in y] for y in yaw_rad]
    rows = ["# step_mm = %.9g" % (step * 1e3), "x_mm,pitch_arcsec%s,t_s,pass" % (",yaw_arcsec" if yaw[0] else "")]
    rows += ["%.6f,%.6f%s,%.1f,1" % ((x_m[0] + i * step) * 1e3, (slope_rad[i] + rocking_rad) * ARCSEC,
                                     yaw[0][i] if yaw[0] else "", t_forward[i]) for i in range(n)]
    rows += ["%.6f,%.6f%s,%.1f,2" % ((x_m[0] + i * step) * 1e3, back[i] * ARCSEC, yaw[1][i] if yaw[1] else "",
                                     t_back[i]) for i in range(n - 1, -1, -1)]
    with open(path, "w") as f:
        f.write("\n".join(rows) + "\n")
