#!/usr/bin/python3
"""guideway report end to end in headless Chromium: the example inputs are produced by the project's own
tools (report/tools/example_inputs.py: guideway simulate dbb, guideway-emulate workpiece, Moody's 1955 plate,
an explanation), one report per analysis and one with all of them is rendered, loaded in
Chromium, and checked: no console errors, no failed or external loads, no scripts, and every plot's SVG has
its axes, axis labels with units, legend (where there are several series) and data paths with points; at
a laptop's width (1400 px) and laid out for A4 print, no two texts of a plot overlap (their boxes as
Chromium lays them out) and none reaches outside its plot.
Screenshots (PNG), A4 print-outs (PDF) and the HTML files are kept in ARTEFACTS as test artefacts.

usage: report_chromium_test.py GUIDEWAY GUIDEWAY_EMULATE SOURCE_DIR MOODY_DIR ARTEFACTS
Chromium missing is a failure (./scripts/setup.sh installs it), never a skip.
"""
import json
import os
import re
import shutil
import subprocess
import sys

GUIDEWAY, EMULATE, SRC, MOODY, ART = sys.argv[1:6]
sys.path.insert(0, os.path.join(SRC, "report", "tools"))
sys.path.insert(0, os.path.join(SRC, "tests", "support"))
import cdp  # noqa: E402
import example_inputs  # noqa: E402
from report_dom import PLOTS_JS, TEXT_BOXES_JS, have_chromium, open_self_contained, text_overlaps  # noqa: E402
from process_support import Checks  # noqa: E402

check = Checks()
EXPLANATION = {}  # the explanation input (its findings and residual curves)


def run(*args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit("command failed (%d): %s\n%s%s" % (r.returncode, " ".join(args), r.stdout, r.stderr))
    return r


# The profile report also gets the traverse and the run-out (for the correlation): their sections by file name.
KIND_OF = {"strai": "straightness", "runou": "runout"}

# Per analysis: the plot kinds expected (kind -> minimum count) and data paths per plot kind.
EXPECTED = {
    "dbb": {"polar": 1},
    "straightness": {"line": 2},
    "unionjack": {"heightmap": 1},
    "runout": {"line": 1},
    "profile": {"line": 1, "panels": 2},  # and under the last profile: the correlation bars
    "explain": {"bar": 1},  # and a line plot when the explanation carries residual curves
    "map": {"line": 6, "vectors": 3},  # each axis' translations and rotations, the volume's three faces
}


UNIT = re.compile(r" / |\u00b5m|/div|deg")


# The A4 print's text width at 96 px per inch: 210 mm less 2 x 12 mm of margin.
A4_TEXT_PX = 703


def check_text_boxes(browser, html, where):
    """No overlapping texts in any plot, on screen and laid out for print (then back to the screen)."""
    for media, width in (("screen", browser.width), ("print", A4_TEXT_PX)):
        browser.call("Emulation.setEmulatedMedia", {"media": media})
        browser.call("Emulation.setDeviceMetricsOverride",
                     {"width": width, "height": browser.height, "deviceScaleFactor": 1, "mobile": False})
        for plot in browser.evaluate(TEXT_BOXES_JS):
            pairs, outside = text_overlaps(plot)
            w = "%s %s at %d px: %s plot '%s'" % (os.path.basename(html), media, width, plot["kind"], plot["title"])
            check(not pairs, w + ": texts overlap: %s" % pairs[:5])
            check(not outside, w + ": texts outside the plot: %s" % outside[:5])
    browser.call("Emulation.setEmulatedMedia", {"media": "screen"})
    browser.call("Emulation.setDeviceMetricsOverride",
                 {"width": browser.width, "height": browser.height, "deviceScaleFactor": 1, "mobile": False})


def check_report(browser, html, kinds):
    kinds = sorted(set(kinds))
    open_self_contained(browser, html, check)
    check_text_boxes(browser, html, kinds)
    sections = browser.evaluate(PLOTS_JS)
    correlation_bars = []
    check(sorted({s["kind"] for s in sections}) == sorted(kinds), "%s: sections %s, expected %s"
          % (html, [s["kind"] for s in sections], kinds))
    for sec in sections:
        where = "%s [%s]" % (os.path.basename(html), sec["kind"])
        check(sec["tables"] >= 1 or sec["kind"] == "profile", where + ": no table")
        counts = {}
        for p in sec["plots"]:
            counts[p["kind"]] = counts.get(p["kind"], 0) + 1
            w = "%s plot '%s' (%s)" % (where, p["title"], p["kind"])
            check(p["width"] > 200 and p["height"] > 100, w + ": not laid out (%sx%s)" % (p["width"], p["height"]))
            axis_classes = " ".join(a["cls"] for a in p["axes"])
            if p["kind"] == "polar":
                check("polar" in axis_classes, w + ": no polar grid")
                check(any("\u00b5m/div" in l for l in p["axis_labels"]), w + ": no um/division scale")
            else:
                check(" x" in " " + axis_classes and " y" in axis_classes, w + ": missing x or y axis: " + axis_classes)
            for a in p["axes"]:
                check(a["ticks"] >= 2, w + ": axis %s has %d ticks" % (a["cls"], a["ticks"]))
                # Stacked panels share one labelled x axis (the bottom one).
                shared_x = p["kind"] == "panels" and a["cls"] == "axis x"
                check(len(a["labels"]) >= 2 or "categorical" in a["cls"] or shared_x,
                      w + ": axis %s tick labels %s" % (a["cls"], a["labels"]))
            if p["kind"] == "panels":
                check(sum(1 for a in p["axes"] if a["cls"] == "axis x" and len(a["labels"]) >= 2) == 1,
                      w + ": the shared x axis has no tick labels")
            # Every axis label names its unit; a bar chart's category axis has none.
            with_unit = [bool(UNIT.search(l) or "angle" in l) for l in p["axis_labels"]]
            check(len(p["axis_labels"]) >= (1 if p["kind"] == "polar" else 2)
                  and (all(with_unit) if p["kind"] != "bar" else any(with_unit)),
                  w + ": axis labels without units: %s" % p["axis_labels"])
            check(len(p["data"]) >= 1, w + ": no data path")
            for dpath in p["data"]:
                check(dpath["d"] > 10 and dpath["segs"] >= 2 and dpath["points"] >= 2,
                      w + ": empty data path %s" % dpath)
                check(dpath["w"] > 1 or dpath["h"] > 1, w + ": data path has no extent %s" % dpath)
            if len(p["data"]) > 1 and p["kind"] in ("line", "polar", "bar"):
                check(len(p["legend"]) >= len([d for d in p["data"] if d["series"]]),
                      w + ": legend %s for series %s" % (p["legend"], [d["series"] for d in p["data"]]))
        for k, n in EXPECTED[sec["kind"]].items():
            check(counts.get(k, 0) >= n, "%s: %d %s plot(s), expected >= %d" % (where, counts.get(k, 0), k, n))
        # Analysis-specific content.
        plots = sec["plots"]
        if sec["kind"] == "dbb":
            polar = [p for p in plots if p["kind"] == "polar"][0]
            check(sorted(d["series"].split()[0] for d in polar["data"]) == ["CCW", "CW"],
                  where + ": CW and CCW not overlaid: %s" % [d["series"] for d in polar["data"]])
            check(all(d["points"] >= 3000 for d in polar["data"]), where + ": runs not plotted whole")
        if sec["kind"] == "explain" and "residuals" in EXPLANATION:
            # The residual before and after each finding: one panel per step, in the order selected, every
            # run drawn in each, all on one y scale.
            steps = [p for p in plots if p["kind"] == "line"]
            effects = [f["effect"] for f in EXPLANATION["findings"]]
            check(len(steps) == 1 + len(effects), where + ": %d residual panels for %d findings" % (len(steps), len(effects)))
            check(len(steps) >= 1 and steps[0]["title"].startswith("Residual of the base model"),
                  where + ": no base-model residual panel: %s" % [p["title"] for p in steps])
            for k, e in enumerate(effects):
                if k + 1 < len(steps):
                    check(("after + %s (finding %d)" % (e.replace("_", " "), k + 1)) in steps[k + 1]["title"],
                          where + ": panel %d is '%s', expected finding %d (%s)" % (k + 1, steps[k + 1]["title"], k + 1, e))
            runs = EXPLANATION["residuals"]["runs"]
            for p in steps:
                check(sorted(d["series"] for d in p["data"]) == sorted(runs),
                      where + ": panel '%s' draws %s, expected the runs %s" % (p["title"], [d["series"] for d in p["data"]], runs))
                check(all(d["points"] == len(EXPLANATION["residuals"]["x"]) for d in p["data"]),
                      where + ": panel '%s' does not draw the whole curve" % p["title"])
            yticks = {tuple(a["labels"]) for p in steps for a in p["axes"] if a["cls"] == "axis y"}
            check(len(yticks) == 1, where + ": the residual panels are not on one y scale: %s" % yticks)
        if sec["kind"] == "map":
            lines = [p for p in plots if p["kind"] == "line"]
            for p in lines:
                check(len(p["data"]) == 3, where + ": plot '%s' draws %d functions, expected 3" % (p["title"], len(p["data"])))
                check(any("2 u" in l for l in p["legend"]), where + ": plot '%s' has no uncertainty band in its legend: %s"
                      % (p["title"], p["legend"]))
            for p in [p for p in plots if p["kind"] == "vectors"]:
                check(any("colorbar" in a["cls"] for a in p["axes"]), where + ": vectors '%s' without colour scale" % p["title"])
                check(all(d["points"] == 49 for d in p["data"]), where + ": vectors '%s': %s" % (p["title"], p["data"]))
        if sec["kind"] == "unionjack":
            hm = [p for p in plots if p["kind"] == "heightmap"][0]
            check(len(hm["data"]) == 8, where + ": %d Union Jack lines, expected 8" % len(hm["data"]))
            check(any("colorbar" in a["cls"] for a in hm["axes"]), where + ": no colour bar scale")
        if sec["kind"] == "profile":
            bars = [p for p in plots if p["kind"] == "bar"]
            correlation_bars.extend(bars)
            for b in bars:
                check(sorted(d["series"] for d in b["data"]) == sorted(
                      ["squareness y1, before (x)", "squareness y1, after (s1)", "straightness y2, before (x)",
                       "straightness y2, after (s1)"]), where + ": correlation bars %s" % [d["series"] for d in b["data"]])
            panels = [p for p in plots if p["kind"] == "panels"]
            names = sorted(n for p in panels for n in [d["series"] for d in p["data"]])
            check(names == sorted(["s", "a1", "a2", "a3", "a4", "a5", "d1", "d2", "d3", "d4", "d5"]),
                  where + ": MRA panels %s" % names)
            for p in panels:
                check(len([a for a in p["axes"] if " y" in a["cls"]]) == p["panels"], where + ": a panel without y axis")
    if "profile" in kinds and "straightness" in kinds:
        check(len(correlation_bars) == 1, "%s: %d correlation charts for the profiles, expected 1"
              % (html, len(correlation_bars)))


def main():
    if not have_chromium():
        return 1
    shutil.rmtree(ART, ignore_errors=True)
    os.makedirs(ART)
    inputs, note = example_inputs.make_inputs(GUIDEWAY, EMULATE, SRC, MOODY, os.path.join(ART, "inputs"))
    print("explanation input:", note)
    global EXPLANATION
    with open(inputs["explain"][0]) as f:
        EXPLANATION = json.load(f)
    # guideway explain writes the residual after each step: the panels below must then be there.
    check(not note.startswith("guideway explain") or len(EXPLANATION.get("residuals", {}).get("steps", [])) ==
          1 + len(EXPLANATION["findings"]), "guideway explain --json has no residual per step")
    if "residuals" in EXPLANATION:
        # One residual panel per step: the base model, then after each finding.
        EXPECTED["explain"]["line"] = 1 + len(EXPLANATION["findings"])
    with cdp.Browser(width=1400) as b:
        for kind, files in inputs.items():
            html = os.path.join(ART, "report_%s.html" % kind)
            run(GUIDEWAY, "report", *files, "--out", html, "--no-date", "--title", "Guideway report: " + kind)
            check_report(b, html, [KIND_OF[os.path.basename(f)[:5]] if os.path.basename(f)[:5] in KIND_OF else kind
                                   for f in files])
            b.screenshot(os.path.join(ART, "report_%s.png" % kind))
        everything = os.path.join(ART, "report_all.html")
        all_files = list(dict.fromkeys(f for files in inputs.values() for f in files))
        run(GUIDEWAY, "report", *all_files, "--out", everything)
        check_report(b, everything, list(inputs))
        pages = b.print_pdf(os.path.join(ART, "report_all.pdf"))
        # Print CSS: each analysis starts on its own A4 page.
        check(pages >= len(inputs), "A4 print-out has %d pages for %d analyses" % (pages, len(inputs)))
        print("A4 print-out: %d pages" % pages)

    # Bad input is an error naming the file (and line), not a report.
    bad = os.path.join(ART, "inputs", "bad_run.csv")
    with open(inputs["dbb"][0]) as f:
        lines = f.read().splitlines()
    idx = next(i for i, l in enumerate(lines) if l and l[0].isdigit()) + 5
    lines[idx] = lines[idx].rsplit(",", 1)[0] + ",abc"
    with open(bad, "w") as f:
        f.write("\n".join(lines) + "\n")
    r = subprocess.run([GUIDEWAY, "report", bad, "--out", os.path.join(ART, "bad.html")], capture_output=True, text=True)
    check(r.returncode == 1 and ("bad_run.csv:%d" % (idx + 1)) in r.stderr,
          "bad run: exit %d, stderr %r (expected the file and line %d)" % (r.returncode, r.stderr, idx + 1))
    check(not os.path.exists(os.path.join(ART, "bad.html")), "bad run: a report was written anyway")
    r = subprocess.run([GUIDEWAY, "report", os.path.join(SRC, "README.md"), "--out", os.path.join(ART, "x.html")],
                       capture_output=True, text=True)
    check(r.returncode == 1 and "README.md" in r.stderr,
          "unrecognised input: exit %d, %r" % (r.returncode, r.stderr))

    print("artefacts in", ART)
    return check.finish("all report checks passed")


if __name__ == "__main__":
    sys.exit(main())
