#!/usr/bin/python3
"""`guideway explain --model traverse` end to end through files: the example machine's X carriage traversed
forward and back by `guideway-emulate workpiece --passes 2` -> the drift and the reflector's rocking that
config/machine-example.toml holds are named with their sizes, nothing else; the readable form; `identify
straightness` evaluates the file's first pass; `--machine` puts the file's values beside; issue 41: short passes
(24 a pass) explained four at a time, a drift over a bow with the base chosen again (no 400 mm wave beside it); clear
errors for a pass that turns or a file too short.

usage: explain_traverse_cli_test.py GUIDEWAY GUIDEWAY_EMULATE
"""
import json
import os
import random
import subprocess
import sys
import tempfile


def run(exe, *args, check=True):
    return subprocess.run([exe, *args], check=check, capture_output=True, text=True)


def write_traverse(path, step_mm, passes=4, drift_arcsec_per_min=0.0, rocking_arcsec=0.0, curve_urad_per_m2=0.0,
                   seed=1):
    """A traverse file over 600 mm: passes forward and back, 2 s a station, 10 s at each turn, 0.05" of noise; the
    slope a bow curve (x - 0.3 m)^2 (urad), plus a drift in time and a rocking with the direction of travel."""
    rnd = random.Random(seed)
    n = int(round(600 / step_mm))
    arcsec = 4.84813681109536  # urad
    t = 0.0
    rows = ["# step_mm = %g" % step_mm, "x_mm,pitch_arcsec,t_s,pass"]
    for k in range(passes):
        stations = range(n) if k % 2 == 0 else range(n - 1, -1, -1)
        for j, i in enumerate(stations):
            x_m = (i * step_mm + step_mm / 2) / 1000
            slope = curve_urad_per_m2 * (x_m - 0.3) ** 2 + drift_arcsec_per_min * arcsec * t / 60
            slope += rocking_arcsec * arcsec * (1 if k % 2 == 0 else -1) + rnd.gauss(0, 0.05 * arcsec)
            rows.append("%g,%.6f,%g,%d" % (i * step_mm, slope / arcsec, t, k + 1))
            t += 2.0 if j < n - 1 else 10.0
    open(path, "w").write("\n".join(rows) + "\n")


def main():
    exe, emulate = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as d:
        run(emulate, "workpiece", "--out-dir", d, "--passes", "2", "--seed", "11")
        trav = os.path.join(d, "straightness.csv")
        header = [l for l in open(trav) if not l.startswith("#")][0].strip()
        assert header == "x_mm,pitch_arcsec,yaw_arcsec,t_s,pass", header
        j = json.loads(run(exe, "explain", "--model", "traverse", trav, "--json").stdout)
        assert j["model"] == "traverse", j["model"]
        found = {f["effect"]: f["parameters"] for f in j["findings"]}
        assert set(found) == {"angle_drift", "reflector_rocking"}, list(found)
        drift = found["angle_drift"]["angle_drift_arcsec_per_min"]
        rock = found["reflector_rocking"]["reflector_rocking_arcsec"]
        assert abs(drift["value"] - 0.1) < 4 * drift["u"], drift   # the example machine's [autocollimator]
        assert abs(rock["value"] - 0.2) < 4 * rock["u"] and rock["u"] < 0.02, rock
        assert j["final"]["heldout_rms_um"] < j["baseline"]["heldout_rms_um"], (j["baseline"], j["final"])
        assert j["unexplained"] is False
        text = run(exe, "explain", "--model", "traverse", trav).stdout
        assert "reflector rocking" in text and "angle drift" in text and "note: what is explained" in text, text

        # --machine: the findings beside the machine file's values, nothing found that the file lacks
        machine = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "config",
                               "machine-example.toml")
        c = json.loads(run(exe, "explain", "--model", "traverse", trav, "--machine", machine, "--json").stdout)
        c = c["against_machine"]
        held = {e["effect"]: (e["machine"], e["found"]) for e in c["findable"]}
        assert abs(held["angle_drift"][0] - 0.1) < 1e-12 and held["angle_drift"][1] == drift["value"], held
        assert abs(held["reflector_rocking"][0] - 0.2) < 1e-12 and held["reflector_rocking"][1] == rock["value"], held
        assert set(held) == {"angle_drift", "reflector_rocking"} and c["not_in_machine"] == [], c
        text = run(exe, "explain", "--model", "traverse", trav, "--machine", machine).stdout
        assert "what the machine file holds" in text and "machine file 0.2" in text, text

        # identify straightness reads the first pass of the same file
        r = run(exe, "identify", "straightness", trav)
        assert "straightness" in r.stdout, r.stdout

        # one pass: no drift or rocking can be told, and the notes say why
        one = os.path.join(d, "one")
        os.mkdir(one)
        run(emulate, "workpiece", "--out-dir", one, "--seed", "11")
        j = json.loads(run(exe, "explain", "--model", "traverse", os.path.join(one, "straightness.csv"),
                           "--json").stdout)
        assert not j["findings"], j["findings"]
        assert any("flips with the direction" in n for n in j["notes"]), j["notes"]

        # errors name the file and line
        bad = os.path.join(d, "bad.csv")
        open(bad, "w").write("# step_mm = 10\nx_mm,pitch_arcsec,t_s\n0,1,0\n10,1,1\n0,1,2\n")
        r = run(exe, "explain", "--model", "traverse", bad, check=False)
        assert r.returncode != 0 and "bad.csv:5" in r.stderr and "not one step" in r.stderr, r.stderr
        # Issue 41 item 6: four passes of 48 readings (600 mm at 12.5 mm), 2 s a station, 10 s at each turn, a drift
        # of 0.25"/min over a bow of 0.45 urad in the slope. The order chosen before the drift was found was 1, and
        # the bow it left was read as a 400 mm pitch wave beside the drift; the base is chosen again once the drift
        # is found: the drift alone, and a note saying what was chosen before. (That wave was the band's longest, 1.5
        # cycles over the span: at the band's edge, where 1.25 cycles fits the bow better, it is refused in the first
        # pass already, docs/explain.md "Inside the grid".)
        bowed = os.path.join(d, "bowed.csv")
        write_traverse(bowed, step_mm=12.5, drift_arcsec_per_min=0.25, curve_urad_per_m2=5.0, seed=3)
        j = json.loads(run(exe, "explain", "--model", "traverse", bowed, "--json").stdout)
        found = {f["effect"]: f["parameters"] for f in j["findings"]}
        assert set(found) == {"angle_drift"}, list(found)
        drift = found["angle_drift"]["angle_drift_arcsec_per_min"]
        assert abs(drift["value"] - 0.25) < 4 * drift["u"], drift
        notes = "\n".join(j["notes"])
        assert "polynomial of order 3" in notes and "the base was chosen again once angle_drift was found" in notes \
            and "and the findings were angle_drift\n" in notes + "\n", notes

        # Issue 41 item 5: 600 mm at 25 mm feet, 24 readings a pass: four passes are explained (their readings tested
        # together); one pass alone is refused, saying why and what would do.
        four = os.path.join(d, "four.csv")
        write_traverse(four, step_mm=25.0, rocking_arcsec=0.3, seed=4)
        j = json.loads(run(exe, "explain", "--model", "traverse", four, "--json").stdout)
        found = {f["effect"]: f["parameters"] for f in j["findings"]}
        assert set(found) == {"reflector_rocking"}, list(found)
        rock = found["reflector_rocking"]["reflector_rocking_arcsec"]
        assert abs(rock["value"] - 0.3) < 4 * rock["u"], rock
        one_short = os.path.join(d, "one_short.csv")
        write_traverse(one_short, step_mm=25.0, passes=1, seed=4)
        r = run(exe, "explain", "--model", "traverse", one_short, check=False)
        assert r.returncode != 0 and "the longest pass has 24 readings and no other pass of its file" in r.stderr \
            and "passes of one file, forward and return, 32 readings or more together" in r.stderr, r.stderr
        assert "24 readings" in run(exe, "identify", "straightness", one_short).stdout

        short = os.path.join(d, "short.csv")
        open(short, "w").write("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,1\n20,1\n")
        r = run(exe, "explain", "--model", "traverse", short, check=False)
        assert r.returncode != 0 and "the longest pass has 3 readings" in r.stderr and "32" in r.stderr, r.stderr
    print("explain_traverse_cli_test: ok")


if __name__ == "__main__":
    main()
