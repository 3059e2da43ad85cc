#!/usr/bin/env python3
"""Golden-file regression of `guideway replay` (like gpsd's regression suite of recorded device logs).

Every raw recording tests/golden/NAME.csv (recorded live by guidewayd from the emulators) is replayed
through the daemon's session code and its PARAMS compared with tests/golden/NAME.params.json, which
holds what the live session published, and its EXPLAIN with NAME.explain.json (the live EXPLAIN when
record_golden.py recorded it, else the reviewed output of --regenerate). Numbers agree to 1e-9
relative; any other difference fails. The text output of the same replay (no --json) must read as a
measurement: no fit internals or unrounded dumps (DUMP_MARKERS).

    replay_golden_test.py GUIDEWAY GOLDEN_DIR              # check
    replay_golden_test.py GUIDEWAY GOLDEN_DIR --regenerate # rewrite the .params.json files from the replay
"""
import json
import math
import pathlib
import subprocess
import sys

IGNORED = {"replayed_from", "recording", "derived"}  # where the files were, not what was identified


def replay(guideway, recording):
    """The replay's PARAMS and EXPLAIN (None when the kind publishes none), without the file names."""
    out = subprocess.run([guideway, "replay", "--json", str(recording)], capture_output=True, text=True, timeout=120)
    if out.returncode != 0:
        raise AssertionError(f"{recording}: guideway replay exited {out.returncode}: {out.stderr}{out.stdout}")
    messages = [json.loads(line) for line in out.stdout.splitlines() if line.strip()]
    params = next(m for m in messages if m["class"] == "PARAMS")
    explain = next((m for m in messages if m["class"] == "EXPLAIN"), None)
    strip = lambda m: None if m is None else {k: v for k, v in m.items() if k not in IGNORED}
    return strip(params), strip(explain)


# What the default (text) output must not show: the fit's internals and unrounded dumps stay in --json.
DUMP_MARKERS = ("condition_number", "diagnostics_fit", "message=", "rms_um=", "+/-", "e+15", "_um ", "_ppm ")


def text_dumps(guideway, recording):
    """The dump markers `guideway replay` (no --json) prints for this recording: none expected."""
    out = subprocess.run([guideway, "replay", str(recording)], capture_output=True, text=True, timeout=120)
    if out.returncode != 0:
        return [f"guideway replay exited {out.returncode}: {out.stderr}"]
    return [f"{m!r} in: {line.strip()}" for line in out.stdout.splitlines() for m in DUMP_MARKERS
            if m in line and not line.startswith(("recording:", "derived:", "replayed "))]


def differences(expected, actual, where=""):
    if isinstance(expected, dict) and isinstance(actual, dict):
        for key in sorted(set(expected) | set(actual)):
            if key in IGNORED and where == "":
                continue
            if key not in actual:
                yield f"{where}/{key}: missing in the replay"
            elif key not in expected:
                yield f"{where}/{key}: not in the golden file"
            else:
                yield from differences(expected[key], actual[key], f"{where}/{key}")
    elif isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            yield f"{where}: {len(actual)} items, golden {len(expected)}"
        for i, (e, a) in enumerate(zip(expected, actual)):
            yield from differences(e, a, f"{where}[{i}]")
    elif isinstance(expected, (int, float)) and isinstance(actual, (int, float)) and not isinstance(expected, bool):
        if not math.isclose(expected, actual, rel_tol=1e-9, abs_tol=1e-12):
            yield f"{where}: {actual!r}, golden {expected!r}"
    elif expected != actual:
        yield f"{where}: {actual!r}, golden {expected!r}"


def main():
    guideway, golden = sys.argv[1], pathlib.Path(sys.argv[2])
    regenerate = "--regenerate" in sys.argv[3:]
    recordings = sorted(p for p in golden.glob("*.csv") if ".run" not in p.name)
    if not recordings:
        print(f"no recordings in {golden}", file=sys.stderr)
        return 1
    failures = 0
    for rec in recordings:
        params, explain = replay(guideway, rec)
        dumps = [] if regenerate else text_dumps(guideway, rec)
        if dumps:
            failures += 1
            print(f"FAIL {rec.name}: the text output shows internals (they belong in --json):")
            for d in dumps[:10]:
                print("   ", d)
        # KIND.params.json: what the live session published; KIND.explain.json: its EXPLAIN.
        for suffix, actual in ((".params.json", params), (".explain.json", explain)):
            expected_path = rec.with_suffix(suffix)
            if regenerate:
                if actual is not None:
                    expected_path.write_text(json.dumps(actual, indent=1, sort_keys=True) + "\n")
                    print(f"regenerated {expected_path.name}")
                continue
            if actual is None and not expected_path.exists():
                continue
            if not expected_path.exists():
                print(f"FAIL {rec.name}: no {expected_path.name} (run with --regenerate)")
                failures += 1
                continue
            if actual is None:
                print(f"FAIL {rec.name}: the replay published no {suffix[1:-5].upper()}, {expected_path.name} expects one")
                failures += 1
                continue
            diffs = list(differences(json.loads(expected_path.read_text()), actual))
            if diffs:
                failures += 1
                print(f"FAIL {rec.name} ({expected_path.name}):")
                for d in diffs[:20]:
                    print("   ", d)
            else:
                print(f"ok   {rec.name} {suffix[1:-5]} ({params.get('kind')}, {params.get('samples')} samples)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
