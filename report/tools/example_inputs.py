"""The example inputs of the report's tests and documentation, made by the project's own tools: DBB runs
(`guideway simulate dbb`, CCW and CW on config/machine-example.toml), Mu's workpiece experiment
(`guideway-emulate workpiece` on tests/models/flatness/workpiece_flatness_mu2012_machine.toml: faced profiles
at 2 and 8 mm/min, the X carriage's autocollimator traverse, a run-out revolution), Moody's 1955 surface plate (real
data) and an explanation (`guideway explain` when the build has it, else the shape example
tests/report/report_explain_example.json, which has no residual curves).
"""
import json
import os
import subprocess


def _run(*args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError("command failed (%d): %s\n%s%s" % (r.returncode, " ".join(args), r.stdout, r.stderr))
    return r


def make_inputs(guideway, emulate, src, moody, out):
    """Writes the inputs into out; returns ({analysis kind: [paths]}, a note on the explanation's origin)."""
    os.makedirs(out, exist_ok=True)
    workpiece_machine = os.path.join(src, "tests", "models", "flatness", "workpiece_flatness_mu2012_machine.toml")
    written = _run(emulate, "workpiece", "--machine", workpiece_machine,
                   "--profile-step-mm", "0.1", "--out-dir", out).stdout.split()
    profiles = sorted(p for p in written if os.path.basename(p).startswith("profile"))
    traverse = [p for p in written if os.path.basename(p).startswith("straightness")]
    runout = [p for p in written if os.path.basename(p).startswith("runout")]
    if len(profiles) < 1 or len(traverse) != 1 or len(runout) != 1:
        raise RuntimeError("guideway-emulate workpiece wrote %s" % written)
    machine = os.path.join(src, "config", "machine-example.toml")
    for direction in ("ccw", "cw"):
        _run(guideway, "simulate", "dbb", "--machine", machine, "--radius-mm", "100", "--direction", direction,
             "--out", os.path.join(out, "dbb_%s.csv" % direction))
    explain = os.path.join(out, "explain.json")
    r = subprocess.run([guideway, "explain", "--model", "dbb", os.path.join(out, "dbb_ccw.csv"),
                        os.path.join(out, "dbb_cw.csv"), "--json"], capture_output=True, text=True)
    if r.returncode == 0 and r.stdout.strip().startswith("{"):
        with open(explain, "w") as f:
            f.write(r.stdout)
        note = "guideway explain --model dbb dbb_ccw.csv dbb_cw.csv --json"
    else:
        # The shape example has no residual curves: they come only from a real explanation.
        with open(os.path.join(src, "tests", "report", "report_explain_example.json")) as f:
            j = json.load(f)
        j.pop("residuals", None)
        with open(explain, "w") as f:
            json.dump(j, f)
        note = ("tests/report/report_explain_example.json (guideway explain unavailable: %s), without residual curves"
                % ((r.stderr.strip().splitlines() or ["no output"])[-1]))
    # The error map of a simulated day on the example machine (docs/map.md).
    day = os.path.join(out, "day")
    _run(guideway, "simulate", "day", "--machine", machine, "--out-dir", day, "--no-runout")
    error_map = os.path.join(out, "map.json")
    _run(guideway, "map", "fit", "--day", os.path.join(day, "day.json"), "--out", error_map, "--quiet", "--grid", "7")
    return {
        "dbb": [os.path.join(out, "dbb_ccw.csv"), os.path.join(out, "dbb_cw.csv")],
        "straightness": traverse,
        "unionjack": [moody],
        "runout": runout,
        # The profiles with the traverse and the run-out: the MRA panels and Mu's correlation bars.
        "profile": profiles + traverse + runout,
        "explain": [explain],
        "map": [error_map],
    }, note
