#!/usr/bin/python3
"""guideway fleet end to end through its commands: a fleet database is filled with `guideway fleet ingest`
(the golden PARAMS and EXPLAIN of every session kind, statuses, a will, duplicates) for two machines, then
`fleet status` (text and --json), `fleet history --json` and `fleet report` are checked against the values
written; the report is loaded in headless Chromium (report/tools: cdp, report_dom) and every trend plot's
axes, units, points and ±2u bars are checked. Screenshots and the HTML are kept in ARTEFACTS.

usage: fleet_cli_test.py GUIDEWAY SOURCE_DIR ARTEFACTS
Chromium missing is a failure (./scripts/setup.sh installs it), never a skip.
"""
import json
import os
import re
import shutil
import subprocess
import sys

GUIDEWAY, SRC, ART = sys.argv[1:4]
sys.path.insert(0, os.path.join(SRC, "report", "tools"))
sys.path.insert(0, os.path.join(SRC, "tests", "support"))
import cdp  # noqa: E402
from report_dom import PLOTS_JS, have_chromium, open_self_contained  # noqa: E402
from process_support import Checks  # noqa: E402

PREFIX = "plant/hall1"
KINDS = ("dbb", "runout", "straightness", "profile")
check = Checks()


def gw(*args, ok=True):
    r = subprocess.run((GUIDEWAY,) + args, capture_output=True, text=True)
    if ok and r.returncode != 0:
        raise SystemExit("command failed (%d): guideway %s\n%s%s" % (r.returncode, " ".join(args), r.stdout, r.stderr))
    return r


def golden(name):
    with open(os.path.join(SRC, "tests", "golden", name)) as f:
        return json.load(f)


def check_a_reader_without_write_access(db):
    """`fleet status` by another user who may read the database but not write it or its directory (the
    service's group, docs/plant.md): runs as `nobody` when the test runs as root, else says it did not."""
    import pwd
    import tempfile
    if os.geteuid() != 0 or not shutil.which("runuser"):
        print("not checked: a reader without write access (needs root and runuser)")
        return
    try:
        pwd.getpwnam("nobody")
    except KeyError:
        print("not checked: a reader without write access (no user nobody)")
        return
    with tempfile.TemporaryDirectory(prefix="gw-fleet-ro-") as d:
        os.chmod(d, 0o755)
        # The reader runs its own copy: the checkout may sit in a folder only its owner may enter.
        exe = os.path.join(d, "guideway")
        shutil.copy(GUIDEWAY, exe)
        os.chmod(exe, 0o755)
        for suffix in ("", "-wal", "-shm"):  # the writer keeps -wal and -shm (SQLITE_FCNTL_PERSIST_WAL)
            check(os.path.exists(db + suffix), "the writer left no %s" % (db + suffix))
            if os.path.exists(db + suffix):
                shutil.copy(db + suffix, os.path.join(d, "fleet.sqlite" + suffix))
                os.chmod(os.path.join(d, "fleet.sqlite" + suffix), 0o644)
        r = subprocess.run(["runuser", "-u", "nobody", "--", exe, "fleet", "status", "--db",
                            os.path.join(d, "fleet.sqlite")], capture_output=True, text=True)
        check(r.returncode == 0 and "mill-1" in r.stdout, "a read-only reader: exit %d %s" % (r.returncode, r.stderr))


def main():
    if not have_chromium():
        return 1
    shutil.rmtree(ART, ignore_errors=True)
    os.makedirs(os.path.join(ART, "payloads"))
    db = os.path.join(ART, "db", "fleet.sqlite")

    # No database yet: every reading command says how to get one.
    for cmd in (["status"], ["history", "mill-1"], ["report", "--out", os.path.join(ART, "x.html")]):
        r = gw("fleet", *cmd, "--db", db, ok=False)
        check(r.returncode == 1 and ("no fleet database at %s: start `guideway fleet serve` first" % db) in r.stderr,
              "fleet %s without a database: exit %d, %r" % (cmd[0], r.returncode, r.stderr))

    def ingest(machine, leaf, payload, produced=None, received=None, name=None):
        path = os.path.join(ART, "payloads", name or "%s_%s.json" % (machine, leaf.replace("/", "_")))
        with open(path, "w") as f:
            f.write(payload if isinstance(payload, str) else json.dumps(payload))
        args = ["fleet", "ingest", "--db", db, "--topic-prefix", PREFIX, "--topic", "%s/%s/%s" % (PREFIX, machine, leaf),
                "--file", path]
        if produced:
            args += ["--produced-utc", produced]
        if received:
            args += ["--received-utc", received]
        return gw(*args, ok=False)

    # mill-1: three DBB results (the third's backlash x moved by 20 u), an EXPLAIN, one of every other kind.
    dbb = golden("dbb.params.json")
    bx = dbb["lai3"]["backlash_x_um"]
    sent = []
    for i, (session, produced, shift) in enumerate((("dbb-a", "2026-11-20T08:00:00.000Z", 0.0),
                                                    ("dbb-b", "2026-11-22T08:00:00.000Z", 0.001),
                                                    ("dbb-c", "2026-11-24T08:00:00.000Z", 20 * bx["u"]))):
        p = json.loads(json.dumps(dbb))
        p["session"] = session
        p["lai3"]["backlash_x_um"]["value"] = bx["value"] + shift
        sent.append(p)
        r = ingest("mill-1", "params/dbb", p, produced, name="dbb_%d.json" % i)
        check(r.returncode == 0 and r.stdout.strip() == "stored", "ingest %s: %r %r" % (session, r.stdout, r.stderr))
    # Delivered again (a retained copy): refused as a duplicate.
    r = ingest("mill-1", "params/dbb", sent[2], "2026-11-24T08:00:00.000Z", name="dbb_again.json")
    check(r.returncode == 0 and r.stdout.strip() == "duplicate", "re-delivered result: %r" % r.stdout)
    check(ingest("mill-1", "explain/dbb", golden("dbb.explain.json"), "2026-11-24T08:00:05Z").stdout.strip() == "stored",
          "dbb explain not stored")
    for k in KINDS[1:]:
        check(ingest("mill-1", "params/" + k, golden(k + ".params.json"), "2026-11-23T10:00:00Z").returncode == 0,
              k + " not stored")
    ingest("mill-1", "status", {"state": "online", "machine": "mill-1", "release": "0.1.0", "since": "2026-11-26T11:00:00Z"})
    # lathe-2: two DBB results, online, then the broker's will (no time: since = when it arrived).
    for i, produced in enumerate(("2026-11-21T09:00:00Z", "2026-11-25T09:00:00Z")):
        p = json.loads(json.dumps(dbb))
        p["session"] = "lathe-%d" % i
        ingest("lathe-2", "params/dbb", p, produced, name="lathe_%d.json" % i)
    ingest("lathe-2", "status", {"state": "online", "machine": "lathe-2", "release": "0.1.0", "since": "2026-11-26T10:00:00Z"})
    ingest("lathe-2", "status", {"state": "offline", "machine": "lathe-2", "reason": "connection lost"},
           received="2026-11-26T10:30:00.250Z", name="will.json")
    # Not ours: an error naming the reason, nothing stored.
    r = ingest("lathe-2", "params/dbb", "{not json", name="bad.json")
    check(r.returncode == 1 and "not JSON" in r.stderr, "bad payload: exit %d %r" % (r.returncode, r.stderr))

    # status, as text: a header, one aligned line per machine, the moved rule.
    r = gw("fleet", "status", "--db", db)
    lines = r.stdout.splitlines()
    print(r.stdout)
    check(len(lines) == 7 and lines[1].startswith("lathe-2") and lines[2].startswith("mill-1"), "status lines: %r" % lines)
    # The EXPLAIN column: in words, largest first, and what its sizes are said under the table.
    check(lines[0].endswith("EXPLAIN (latest, largest first)") and
          lines[2].endswith("dbb: backlash 1.99 µm, vibration 0.0246 µm") and
          lines[4].startswith("EXPLAIN: the effects") and "range about the least-squares circle" in lines[4],
          "status EXPLAIN column: %r" % lines)
    # The malformed payload: counted, with its reason and topic, under the table.
    check(lines[5].startswith("refused at ingest: 1 message(s)") and "lathe-2/params/dbb" in lines[6]
          and "not JSON" in lines[6], "refusals: %r" % lines[5:])
    check("offline (connection lost)" in lines[1] and " online " in lines[2], "status states: %r" % lines[1:3])
    check("G/µm" in lines[0] and "backlash X/µm" in lines[0] and "run-out/µm" in lines[0], "status header: %r" % lines[0])
    col = lines[0].index("LAST DBB")
    check(all(len(l) > col and l[col - 2:col] == "  " for l in lines[:3]), "status columns not aligned: %r" % lines[:3])
    check("k = 2" in lines[3] and "never flagged" in lines[3], "status: no moved rule: %r" % lines[3])
    bcol = lines[0].index("backlash X/µm") + len("backlash X/µm")
    check(lines[2][bcol] == "*" and lines[1][bcol] == " ", "backlash x moved mark: %r / %r" % (lines[2], lines[1]))

    st = json.loads(gw("fleet", "status", "--db", db, "--json").stdout)
    by = {m["machine"]: m for m in st["machines"]}
    check(sorted(by) == ["lathe-2", "mill-1"], "status machines %s" % sorted(by))
    lathe = by["lathe-2"]
    check(lathe["state"] == "offline" and lathe["since"] == "2026-11-26T10:30:00.250Z" and lathe["reason"] == "connection lost",
          "will: %s" % {k: lathe[k] for k in ("state", "since", "reason")})
    mill = by["mill-1"]
    figs = {f["name"]: f for f in mill["latest"]["dbb"]["figures"]}
    check(mill["latest"]["dbb"]["session"] == "dbb-c", "latest dbb: %s" % mill["latest"]["dbb"]["session"])
    check(figs["backlash_x_um"]["value"] == sent[2]["lai3"]["backlash_x_um"]["value"] and figs["backlash_x_um"]["moved"],
          "backlash x: %s" % figs["backlash_x_um"])
    check(not figs["backlash_y_um"]["moved"] and not figs["circular_deviation_um"]["moved"]
          and "u" not in figs["circular_deviation_um"], "G/backlash y flags: %s" % figs)
    check(mill["latest"]["runout"]["figures"][0]["value"] == golden("runout.params.json")["squareness"]["squareness_urad"]["value"],
          "runout squareness: %s" % mill["latest"]["runout"])
    check([f["effect"] for f in mill["explain"]["dbb"]["findings"]] == ["backlash", "vibration"],
          "explain: %s" % mill["explain"])
    check(mill["dbb_age_s"] > 0 and lathe["dbb_age_s"] < mill["dbb_age_s"], "ages: %s %s" % (mill["dbb_age_s"], lathe["dbb_age_s"]))

    # history: every DBB result, oldest first, each figure value ± u as sent.
    h = json.loads(gw("fleet", "history", "mill-1", "--kind", "dbb", "--db", db, "--json").stdout)
    params = [x for x in h["results"] if x["class"] == "PARAMS"]
    check([x["session"] for x in params] == ["dbb-a", "dbb-b", "dbb-c"], "history order: %s" % [x["session"] for x in params])
    check(len(h["results"]) == 4 and h["results"][-1]["class"] == "EXPLAIN", "history with the explain: %d" % len(h["results"]))
    for x, p in zip(params, sent):
        f = {g["name"]: g for g in x["figures"]}
        check(f["backlash_x_um"]["value"] == p["lai3"]["backlash_x_um"]["value"]
              and f["backlash_x_um"]["u"] == p["lai3"]["backlash_x_um"]["u"]
              and f["circular_deviation_um"]["value"] == p["diagnostics"]["circular_deviation_um"]["value"],
              "history %s figures: %s" % (x["session"], f))
    check([next(g for g in x["figures"] if g["name"] == "backlash_x_um")["moved"] for x in params] == [False, False, True],
          "history moved flags")
    text = gw("fleet", "history", "mill-1", "--db", db).stdout
    check("backlash X: 0.9956 ± 0.0080 µm" in text and "found: backlash 1.99 µm" in text, "history text:\n" + text)
    r = gw("fleet", "history", "drill-9", "--db", db, ok=False)
    check(r.returncode == 1 and "unknown machine 'drill-9'; known: lathe-2, mill-1" in r.stderr, "unknown machine: %r" % r.stderr)

    # report: self-contained, in Chromium.
    html = os.path.join(ART, "fleet.html")
    gw("fleet", "report", "--db", db, "--out", html, "--no-date")
    with cdp.Browser() as b:
        open_self_contained(b, html, check)
        tables = b.evaluate("""(() => [...document.querySelectorAll('section#fleet table')].map(t =>
            [...t.querySelectorAll('tbody tr')].map(r =>
            [...r.cells].map(c => ({text: c.textContent, align: getComputedStyle(c).textAlign})))))()""")
        check(len(tables) == 2, "the fleet section: %d tables (figures, EXPLAIN)" % len(tables))
        for row in tables[0]:
            machine = row[0]["text"]
            # A page read later: when the last DBB was made, and how long before the report.
            check(re.match(r"20\d\d-\d\d-\d\d \d\d:\d\d, .* before this report", row[2]["text"]),
                  "%s: last DBB %r" % (machine, row[2]["text"]))
            check(re.match(r"(online|offline).*20\d\d-\d\d-\d\d \d\d:\d\d$", row[1]["text"]),
                  "%s: state since %r" % (machine, row[1]["text"]))
            check([c["align"] for c in row[:3]] == ["left"] * 3,
                  "%s: text columns not left-aligned: %s" % (machine, [c["align"] for c in row]))
            check(all(c["align"] == "right" for c in row[3:]), "%s: a figure column is not right-aligned" % machine)
        # What EXPLAIN found, in a table of its own (a column beside the figures was a word a line): in words,
        # largest first, left-aligned.
        found = {r[0]["text"]: r for r in tables[1]}
        check(list(found) == ["mill-1"] and found["mill-1"][3]["text"] == "backlash 1.99 µm, vibration 0.0246 µm"
              and all(c["align"] == "left" for c in found["mill-1"]), "EXPLAIN table: %r" % tables[1])
        sections = b.evaluate(PLOTS_JS)
        check([s["kind"] for s in sections] == ["fleet", "machine", "machine"], "sections %s" % [s["kind"] for s in sections])
        check(sections[0]["tables"] == 2, "the fleet section's tables: %d" % sections[0]["tables"])
        expected_plots = {"lathe-2": 3, "mill-1": 3 + 2 + 2 + 2}  # dbb: G, backlash x/y; 2 of every other kind
        for sec in sections[1:]:
            # One id per name: letters, digits and '_' as they are, any other byte '-' and two hex digits.
            name = re.sub(r"-([0-9a-f]{2})", lambda m: chr(int(m.group(1), 16)), sec["id"][len("machine-"):])
            check(len(sec["plots"]) == expected_plots.get(name, -1), "%s: %d plots" % (name, len(sec["plots"])))
            for p in sec["plots"]:
                w = "%s plot '%s'" % (name, p["title"])
                check(p["width"] > 200 and p["height"] > 100, w + ": not laid out")
                classes = [a["cls"] for a in p["axes"]]
                check("axis x" in classes and "axis y" in classes, w + ": axes %s" % classes)
                check(all(len(a["labels"]) >= 2 for a in p["axes"]), w + ": tick labels %s" % [a["labels"] for a in p["axes"]])
                check(len(p["axis_labels"]) == 2 and p["axis_labels"][0].startswith("time / days since 2026-11-2")
                      and all(" / " in l for l in p["axis_labels"]), w + ": axis labels %s" % p["axis_labels"])
                series = {d["series"]: d for d in p["data"]}
                n = 3 if name == "mill-1" and p["title"].startswith("dbb") else (2 if name == "lathe-2" else 1)
                check(series.get("value", {}).get("points") == n, w + ": value points %s, expected %d" % (series, n))
                has_u = not p["title"].endswith(": G")
                # The value axis spans at least a fifth of the largest value: equal Gs are a flat line.
                y_ticks = [float(t.replace("−", "-")) for a in p["axes"] if a["cls"] == "axis y" for t in a["labels"]]
                if p["title"].endswith(": G"):
                    check(max(y_ticks) - min(y_ticks) >= 0.15 * 17.4, w + ": G axis ticks %s" % y_ticks)
                check(("±2u" in series) == has_u, w + ": ±2u bars %s" % list(series))
                if has_u:
                    check(series["±2u"]["points"] == 3 * n and series["±2u"]["h"] > 0, w + ": bars %s" % series["±2u"])
                    check("±2u" in p["legend"] and "value" in p["legend"], w + ": legend %s" % p["legend"])
        b.screenshot(os.path.join(ART, "fleet.png"))
    check_a_reader_without_write_access(db)
    print("artefacts in", ART)
    return check.finish("all fleet checks passed")


if __name__ == "__main__":
    sys.exit(main())
