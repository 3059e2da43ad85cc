#!/usr/bin/python3
"""`guideway explain --model traverse` end to end through files: the example machine's X carriage traversed
forward and back by `guideway-emulate workpiece --passes 2` -> the drift and the reflector's rocking that
config/machine-example.toml holds are named with their sizes, nothing else; the readable form; `identify
straightness` evaluates the file's first pass; `--machine` puts the file's values beside; clear errors for a pass that turns or a file too short.

usage: explain_traverse_cli_test.py GUIDEWAY GUIDEWAY_EMULATE
"""
import json
import os
import subprocess
import sys
import tempfile


def run(exe, *args, check=True):
    return subprocess.run([exe, *args], check=check, capture_output=True, text=True)


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
        machine = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "machine-example.toml")
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
        short = os.path.join(d, "short.csv")
        open(short, "w").write("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,1\n20,1\n")
        r = run(exe, "explain", "--model", "traverse", short, check=False)
        assert r.returncode != 0 and "the longest pass has 3 readings" in r.stderr and "32" in r.stderr, r.stderr
    print("explain_traverse_cli_test: ok")


if __name__ == "__main__":
    main()
