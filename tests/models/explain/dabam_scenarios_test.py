#!/usr/bin/python3
"""EXPLAIN's scenarios on real backgrounds: the real flats of tests/data/dabam (DABAM, GPL-2.0: see its README),
each re-read as a forward and a return pass, explained by `guideway explain --model traverse` (issue 41 item 9).

usage: dabam_scenarios_test.py GUIDEWAY DABAM_DIR [--quick]

Each flat (the two long scans of 9,230 readings among them) is read forward, then back over the same stations (2 s a station, the return with
fresh noise of 10 % of the profile's slope RMS, the entry's number seeding it), as dabam_explain_cli_test.py
builds its passes. The scenarios of a flat:
  - alone: the two passes with no effect: no finding (what the passes share is the base's geometry);
  - rocking: a reflector rocking of 1x the profile's slope RMS (the std of its slopes), +r forward and -r back:
    found, named reflector_rocking with its size within 20 %, and nothing beside it;
  - turnaround: the same rocking, and the return pass's first readings settling after the reversal (5x the slope
    RMS, decaying over 3 readings): a place no effect explains, set aside where the return pass begins. The
    reading's offset after it would be the rocking's own column (issue 41 item 4: the rocking vanished from
    `considered` on all ten); it is not fitted, and the rocking is found as before, nothing beside it;
  - wave: a pitch wave of 1x the slope RMS, 8 cycles over the stations, that both passes read (a machine's rack or
    lead screw): geometry the base's term per station holds, judged against the geometry's own spectrum
    (models/explain/shared_wave.hpp): found, named pitch_wave with its size within 20 %, nothing beside it. Before,
    it was found on none (`cannot be fitted: every variant lies in what the base fit`);
  - drift: the instrument's zero drifting 1x the slope RMS from the first reading to the last: found, named
    angle_drift with its rate within 20 %, nothing beside it;
  - yaw: a yaw coupling (the head turned 3 deg about its beam: the pitch reads sin 3 deg of the carriage's yaw, which
    the yaw_arcsec column gives): the yaw a wave of 5 cycles that both passes read, its share of the pitch 1x the
    slope RMS, and a tenth of it more or less at each stop (the carriage's repeatability, fresh each pass): found,
    named yaw_coupling within 20 %, nothing beside it; and beside the wave above, the coupling found and nothing false
    (the wave counted, not required: see docs/explain.md "Limits");
  - chip: a chip caught under a foot 40 % into the return pass, tilting its later readings by 1x the slope RMS
    (ExplainIsoTraverse.AChipUnderAFootIsUnexplainedNotAFinding's): no finding, unexplained or set aside; at 5x its
    findings are printed, not judged (a drift is found beside it on two flats: docs/explain.md "Limits").
The drift and the yaw coupling are judged where their expected t exceeds 5 (issue 41's done-when): expected_t, from
the design; it is 13-555 on every flat, so each must be found on every one.
Judged over the twelve flats as issue 41 asks: the rocking in both and the wave on 90 % of them or more, no finding
alone on every flat, no other finding beside a rocking or the wave on any. The tables are printed in
docs/explain.md's form ("Real flats as forward and return passes"). The whole set costs ~6 s of CPU in Release (the
term per station fitted out of the readings: 0.1-0.5 s for the long scans; as columns 441-481 stations took 5 s a run
and the long scans could not have it); under a sanitizer (--quick) three small flats run, each judged alone, for the
code paths: 052 with the yaw coupling (a term per station from the first: the coupling's wave in the geometry, once
taken for a pitch wave), 053 with it (the polynomial first, chosen again once the coupling is found), 054 with the
chip (the drift's code is every run's: it is a candidate wherever the passes have times).
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from dabam_passes import ARCSEC, forward_and_return, pitch_wave, read_entry

GUIDEWAY, DABAM = sys.argv[1], sys.argv[2]
QUICK = "--quick" in sys.argv[3:]
FLATS = ["dabam-052", "dabam-053", "dabam-054"] if QUICK else [
    "dabam-009", "dabam-030", "dabam-031", "dabam-034", "dabam-052", "dabam-053", "dabam-054", "dabam-059",
    "dabam-060", "dabam-061", "dabam-072", "dabam-073"]
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def explain(path):
    p = subprocess.run([GUIDEWAY, "explain", "--model", "traverse", "--quiet", "--json", "--instrument",
                        "deflectometer", path], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        return None, p.stderr.strip()
    return json.loads(p.stdout), ""


SCENARIOS = (("rocking", 0.0), ("turnaround", 5.0))
found_in = {k: 0 for k in ("rocking", "turnaround", "wave")}
alone_clean, beside_clean, rows = 0, 0, []
# The drift, the yaw coupling and the chip: every flat in the full run; under a sanitizer (--quick), those named.
LATER = {"dabam-052": ("yaw",), "dabam-053": ("yaw",), "dabam-054": ("chip",)} if QUICK else {}
later_ok = {k: [] for k in ("drift", "yaw", "yaw+wave", "chip")}
later_rows, wave_beside = [], 0


def judged(name, what, path, truths):
    """The effects of `truths` ((effect, parameter, truth) each) found in the passes written at `path`: whether each is
    found within 20 % of its truth (a list), their sizes (NaN: missed), the other findings, the missed ones'
    verdicts, and their u."""
    rep, err = explain(path)
    check(rep is not None, "%s with %s as two passes: explained (%s)" % (name, what, err))
    found = {f["effect"]: f["parameters"] for f in rep["findings"]} if rep else {}
    verdict = {c["effect"]: c["verdict"] for c in rep["considered"]} if rep else {}
    values = [found.get(effect, {}).get(parameter, {}) for effect, parameter, _ in truths]
    sizes = [v.get("value", float("nan")) for v in values]
    hits = [abs(size - truth) < 0.2 * truth for size, (_, _, truth) in zip(sizes, truths)]
    why = "; ".join(verdict.get(effect, "not in considered") for hit, (effect, _, _) in zip(hits, truths) if not hit)
    return (hits, sizes, sorted(e for e in found if e not in [t[0] for t in truths]), why,
            [v.get("u", float("nan")) for v in values])


def rocking_case(name, x, slope, seed, settling, path):
    """The rocking's size found (NaN: missed), the other findings, and the rocking's verdict when missed."""
    r_arcsec = np.std(slope) * ARCSEC
    forward_and_return(path, x, slope, r_arcsec / ARCSEC, seed, settling)
    hits, sizes, others, why, _ = judged(name, "a rocking (settling %g)" % settling, path,
                                         [("reflector_rocking", "reflector_rocking_arcsec", r_arcsec)])
    return hits[0], sizes[0], others, why


def wave_case(name, x, slope, seed, path):
    """A pitch wave of 1x the slope RMS, 8 cycles over the stations, read by both passes: as rocking_case."""
    forward_and_return(path, x, slope, 0.0, seed, shared_rad=pitch_wave(x, np.std(slope)))
    hits, sizes, others, why, _ = judged(name, "a pitch wave both read", path,
                                         [("pitch_wave", "pitch_wave_arcsec", np.std(slope) * ARCSEC)])
    return hits[0], sizes[0], others, why


def expected_t(size, rms, disagreement):
    """A term's expected t: its size over the u the fit gives it. The term per station takes what the passes share,
    so a term is told by what it adds to the return less the forward reading at each station (`disagreement`, per
    unit of it), against that difference's noise (the return's 10 % of the slope RMS): least squares of the term
    alone, as it is fitted (no rocking beside it takes the difference's mean)."""
    return size / (0.1 * rms / np.sqrt(np.sum(disagreement ** 2)))


def drift_case(name, x, slope, seed, path):
    """The instrument drifting 1x the slope RMS over the two passes (their first reading to their last): found,
    named angle_drift, its rate within 20 %, nothing beside it. Also its expected t and the fit's u."""
    n, rms = len(x), np.std(slope)
    rate = rms / (2.0 * (2 * n - 1) + 10)  # rad/s: the last reading is at 2 (2n - 1) + 10 s
    forward_and_return(path, x, slope, 0.0, seed, drift_rad_per_s=rate)
    t = expected_t(rate, rms, 2.0 * (2 * n - 1 - 2 * np.arange(n)) + 10)  # the return's time less the forward's
    return judged(name, "a drift", path, [("angle_drift", "angle_drift_arcsec_per_min", rate * ARCSEC * 60)]) + (t,)


SIN_R = np.sin(np.radians(3.0))  # the head turned 3 deg about its beam, as traverse_yaw_coupling's


def yaw_case(name, x, slope, seed, path, wave=False):
    """A yaw coupling: the carriage yaws in a wave of 5 cycles over the stations that both passes read, and by a
    tenth of its amplitude more or less at each stop (its repeatability: fresh each pass); the pitch reads sin 3 deg
    of it, the wave's share 1x the slope RMS. The wave in the pitch is geometry to the term per station; the stops'
    disagreement tells the coupling. Found, named yaw_coupling, within 20 %, nothing beside it. With `wave`, beside
    wave_case's pitch wave (8 cycles): the coupling found and nothing false; the wave counted (the yaw's shape taken
    from the geometry, traverse_explain.cpp judge_shared_wave, leaves a wave of another period, but not always the
    candidate: docs/explain.md "Limits")."""
    n, rms = len(x), np.std(slope)
    amplitude, rs = rms / SIN_R, np.random.RandomState(seed + 1000)
    shape = pitch_wave(x, amplitude, cycles=5, phase_rad=0.3)
    yaw = (shape + rs.normal(0.0, 0.1 * amplitude, n), shape + rs.normal(0.0, 0.1 * amplitude, n))
    forward_and_return(path, x, slope, 0.0, seed, yaw_rad=yaw, coupling=SIN_R,
                       shared_rad=pitch_wave(x, rms) if wave else 0.0)
    t = expected_t(SIN_R, rms, yaw[1] - yaw[0])
    return judged(name, "a yaw coupling" + (" beside a pitch wave" if wave else ""), path,
                  [("yaw_coupling", "yaw_coupling_percent", 100 * SIN_R)] +
                  ([("pitch_wave", "pitch_wave_arcsec", rms * ARCSEC)] if wave else [])) + (t,)


def chip_case(name, x, slope, seed, path, size=1.0):
    """A chip caught under a foot 40 % into the return pass, tilting its later readings by `size` x the slope RMS: no
    effect of the library is that, so no finding, and the readings unexplained or the place set aside."""
    forward_and_return(path, x, slope, 0.0, seed, chip=(0.4, size * np.std(slope)))
    rep, err = explain(path)
    check(rep is not None, "%s with a chip under a foot as two passes: explained (%s)" % (name, err))
    findings = sorted(f["effect"] for f in rep["findings"]) if rep else ["(failed)"]
    return findings, bool(rep and rep["unexplained"]), rep.get("set_aside_samples", 0) if rep else 0


with tempfile.TemporaryDirectory() as tmp:
    for name in FLATS:
        x, slope = read_entry(DABAM, name)
        seed = int(name.split("-")[1])
        r_arcsec = np.std(slope) * ARCSEC
        path = os.path.join(tmp, name + ".csv")
        forward_and_return(path, x, slope, 0.0, seed)
        alone, err = explain(path)
        check(alone is not None, "%s alone as two passes: explained (%s)" % (name, err))
        alone_findings = sorted(f["effect"] for f in alone["findings"]) if alone else ["(failed)"]
        alone_clean += alone_findings == []
        cells, clean = [], True
        for label, settling in SCENARIOS + (("wave", None),):
            ok, size, others, why = (wave_case(name, x, slope, seed, path) if settling is None else
                                     rocking_case(name, x, slope, seed, settling, path))
            found_in[label] += ok
            clean = clean and not others
            cells.append(("%.4f\"" % size if ok else "missed: " + why) + (" + " + ", ".join(others) if others else ""))
            if QUICK:  # each judged alone: a code path, not a rate
                check(ok and not others, "%s (%s): %.4f\" found, %.4f\" (others: %s; %s)"
                      % (name, label, r_arcsec, size, others, why))
        beside_clean += clean
        rows.append((name, len(x), r_arcsec, cells, alone_findings))
        if QUICK:
            check(alone_findings == [], "%s alone: no finding (%s)" % (name, alone_findings))
        cells = {}
        for label, case in (("drift", drift_case), ("yaw", yaw_case),
                            ("yaw+wave", lambda *a: yaw_case(*a, wave=True))):
            if label not in LATER.get(name, (label,)):
                continue
            hits, sizes, others, why, us, t = case(name, x, slope, seed, path)
            later_ok[label].append(hits[0] and not others)  # beside the wave: the coupling, and nothing false
            wave_beside += hits[1:] == [True]
            found = ", ".join("%.4g +/- %.2g" % (size, u) if hit else "missed" for hit, size, u in zip(hits, sizes, us))
            cells[label] = found + (": " + why if why else "") + (" + " + ", ".join(others) if others else "") + \
                ("" if label == "yaw+wave" else " | %.0f" % t)
            check(t > 5 and later_ok[label][-1], "%s (%s): found %s (expected t %.1f; others: %s; %s)"
                  % (name, label, found, t, others, why))
        for size in (1.0,) if QUICK else (1.0, 5.0):  # 5x is reported, not judged: docs/explain.md "Limits"
            if "chip" not in LATER.get(name, ("chip",)):
                break
            findings, unexplained, set_aside = chip_case(name, x, slope, seed, path, size)
            cells["chip", size] = (", ".join(findings) or "none") + (", unexplained" if unexplained else "") + \
                (", %d readings set aside" % set_aside if set_aside else "")
            if size == 1.0:
                later_ok["chip"].append(findings == [] and (unexplained or set_aside > 0))
                check(later_ok["chip"][-1], "%s (chip under a foot): no finding, unexplained or set aside (findings: "
                      "%s; unexplained %s; set aside %d)" % (name, findings, unexplained, set_aside))
        later_rows.append((name, len(x), r_arcsec, cells))

print("| flat | readings a pass | 1x slope RMS | rocking found | rocking found, settling after the reversal | "
      "pitch wave both read (8 cycles) found | alone |")
print("|---|---|---|---|---|---|---|")
for name, n, r, cells, alone_findings in rows:
    print("| %s | %d | %.4f\" | %s | %s | %s | %s |" % (name, n, r, cells[0], cells[1], cells[2],
                                                    ", ".join(alone_findings) or "none"))
print("rocking found (size within 20 %%): %d of %d; with a settling after the reversal: %d of %d; the pitch wave: %d of "
      "%d; alone, no finding: %d of %d; nothing beside the rocking or the wave: %d of %d"
      % (found_in["rocking"], len(FLATS), found_in["turnaround"], len(FLATS), found_in["wave"], len(FLATS),
         alone_clean, len(FLATS), beside_clean, len(FLATS)))
print()
print("| flat | 1x slope RMS | drift of 1x over the passes (\"/min) | found (+/- u) | expected t | "
      "yaw coupling found (%.3f %%, +/- u) | expected t | beside a pitch wave of 1x (8 cycles): coupling, wave found | "
      "chip under a foot, 1x | 5x (not judged) |" % (100 * SIN_R))
print("|---|---|---|---|---|---|---|---|---|---|")
for name, n, r, cells in later_rows:
    print("| %s | %.4f\" | %.4g | %s | %s | %s | %s | %s |" % (name, r, r / (2.0 * (2 * n - 1) + 10) * 60,
                                                         cells.get("drift", "- | -"), cells.get("yaw", "- | -"),
                                                         cells.get("yaw+wave", "-"), cells.get(("chip", 1.0), "-"),
                                                         cells.get(("chip", 5.0), "-")))
print(("the drift found (within 20 %%, nothing beside it): %d of %d; the yaw coupling: %d of %d; beside a pitch wave, "
       "the coupling (nothing false beside): %d of %d; the chip, no finding and unexplained or set aside: %d of %d"
       % tuple(v for k in later_ok for v in (sum(later_ok[k]), len(later_ok[k])))) +
      "; the wave beside the coupling: %d of %d" % (wave_beside, len(later_ok["yaw+wave"])))
if not QUICK:
    for label in found_in:
        check(found_in[label] >= 0.9 * len(FLATS), "%s: 1x the slope RMS found on %d of %d flats (90 %% or more)"
              % (label, found_in[label], len(FLATS)))
    check(alone_clean == len(FLATS), "the two passes alone: no finding on %d of %d flats" % (alone_clean, len(FLATS)))
    check(beside_clean == len(FLATS), "nothing found beside the rocking or the wave on %d of %d flats"
          % (beside_clean, len(FLATS)))

if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
