#!/usr/bin/python3
"""Regenerates the screenshots of docs/reports.md: renders the example inputs (example_inputs.py) into one
report, loads it in headless Chromium and saves one PNG per plot type into docs/img/.

usage: screenshots.py GUIDEWAY GUIDEWAY_EMULATE [OUT_DIR]   (run by report/tools/docs_screenshots.sh)
"""
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import cdp  # noqa: E402
import example_inputs  # noqa: E402

# (file name, CSS selector of the plot, what it shows)
SHOTS = [
    ("report_dbb_polar.png", 'section[data-kind="dbb"] svg.plot[data-plot="polar"]', "DBB polar plot"),
    ("report_dbb_ranking.png", 'section[data-kind="dbb"] svg.plot[data-plot="bar"]', "DBB: what to fix first"),
    ("report_straightness.png", 'section[data-kind="straightness"] svg.plot[data-plot="line"]', "straightness"),
    ("report_unionjack.png", 'section[data-kind="unionjack"] svg.plot[data-plot="heightmap"]', "Union Jack"),
    ("report_runout.png", 'section[data-kind="runout"] svg.plot[data-plot="line"]', "run-out"),
    ("report_profile_mra.png", 'section[data-kind="profile"] svg.plot[data-plot="panels"]', "MRA panels"),
    ("report_profile_correlation.png", 'section[data-kind="profile"] svg.plot[data-plot="bar"]',
     "correlation before/after the wavelet step"),
    ("report_explain.png", 'section[data-kind="explain"] svg.plot[data-plot="bar"]', "explanation"),
    ("report_explain_residuals.png", 'section[data-kind="explain"] div.residual-steps',
     "explanation: residual before and after each finding"),
    ("report_page.png", None, "the top of the page"),
]


def main():
    guideway, emulate = sys.argv[1:3]
    out = sys.argv[3] if len(sys.argv) > 3 else os.path.join(SRC, "docs", "img")
    moody = os.path.normpath(os.path.join(SRC, "tests", "data", "moody1955"))
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="guideway-report-docs-") as tmp:
        inputs, note = example_inputs.make_inputs(guideway, emulate, SRC, moody, os.path.join(tmp, "inputs"))
        html = os.path.join(tmp, "report.html")
        files = list(dict.fromkeys(f for fs in inputs.values() for f in fs))
        example_inputs._run(guideway, "report", *files, "--out", html, "--no-date", "--title", "Guideway report (examples)")
        with cdp.Browser(width=860, height=1000) as b:
            b.open("file://" + html)
            problems = b.problems()
            if problems:
                raise SystemExit("the report has problems in Chromium: %s" % problems)
            for name, selector, what in SHOTS:
                path = os.path.join(out, name)
                if selector:
                    b.screenshot(path, selector)
                else:
                    b.call("Emulation.setDeviceMetricsOverride", {"width": 860, "height": 700, "deviceScaleFactor": 1,
                                                                  "mobile": False})
                    data = b.call("Page.captureScreenshot", {"format": "png"})["data"]
                    import base64
                    with open(path, "wb") as f:
                        f.write(base64.b64decode(data))
                print("%s: %s" % (os.path.relpath(path, SRC) if path.startswith(SRC) else path, what))
    print("explanation input:", note)


if __name__ == "__main__":
    main()
