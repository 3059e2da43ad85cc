#!/usr/bin/env python3
"""The README's expected demo output, taken from a real run.

  scripts/readme_demo.py refresh [--from FILE] [-- DEMO ARGS...]
      runs ./scripts/demo.sh (or reads its saved output from FILE), writes the whole output (standard
      output and error, as a terminal shows them) to
      docs/demo-transcript.txt (the user's paths replaced by /home/you and /run/user/1000) and rewrites
      the README's abridged block between its demo-output markers from it
  scripts/readme_demo.py check
      every line the README quotes is in docs/demo-transcript.txt, in the same order, and the block is
      what `refresh` would write from that transcript (exit 1 and the first difference otherwise)
  scripts/readme_demo.py rerun [--from FILE] [-- DEMO ARGS...]
      runs the demo anew (or reads its saved output) and checks that every line the README quotes is
      in it, in its section (sections in order), up to numbers (a live run's figures differ in their last digits; every run of
      digits is compared as one number-shaped word, a table's column spacing as one space) and the build's progress (it depends on what is
      already built): the README still says what the demo does (the slow test readme_demo_rerun_test)

Which lines the abridged block keeps is said below, per section of the demo (the "== ..." lines): the
lines a newcomer is told to look at; everything left out in between becomes one "...".
"""

import argparse
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
TRANSCRIPT = os.path.join(ROOT, "docs", "demo-transcript.txt")
BEGIN = "<!-- demo-output:begin (scripts/readme_demo.py refresh writes this block) -->"
END = "<!-- demo-output:end -->"
INDENT = "   "  # the block sits in the README's first list item

# Section (by the start of its "== " line) -> the lines kept. A rule is a regular expression searched in
# the line, "first RE" (only its first match), "after N RE" (a match and the N lines after it), "head N"
# (the section's first N lines) or "tail N" (its last N).
KEEP = [
    ("== building", ["head 2", "tail 1"]),
    ("== starting guidewayd", ["head 9"]),
    ("== guideway status", ["head 20"]),
    ("== guideway start dbb", ["head 3", r"first ^\s+\[\d+ s\] running", r"^session .*model", r"^runs:",
                               r"^\s+run \d+ ", r"^ISO 230-4", r"^\s+G\s", r"^ballbar diagnostics",
                               r"^\s+squareness\s", r"first ^\s+backlash X\s", r"first ^\s+backlash Y\s",
                               r"first ^\s+scale mismatch\s", r"after 3 ^what to fix first", r"^note:",
                               r"^recording:"]),
    ("== guideway start runout", ["head 3", r"^session .*model", r"^squareness:", r"^\s+run-out\s", r"^error motion:",
                                  r"^\s+(total|synchronous|asynchronous) error motion\s"]),
    ("== guideway explain --latest --kind runout", ["head 2", r"^explanation", r"^  \S+  \S+ = ",
                                                    r"^what the machine file", r"found .* machine file"]),
    ("== guideway explain", ["head 2", r"^explanation", r"^  \S+  \S+ = ", r"largest first", r"^what the machine file",
                             r"found .* machine file", r"^Lai's base", r"^  \(a centre offset is", r"^not observable"]),
    ("== guideway compensate", ["head 5", r"^\s+term\s", r"^\s+(scale|backlash) [XY]\s+-?\d", r"^\s+squareness ",
                                r"^verification", r"^\s+run\s+G before", r"^\s+r \d+ mm .* µm",
                                r"after 4 circular deviation G:", r"^\s+still above", r"DO NOT LOAD \S+:",
                                r"fit to load"]),
    ("== before/after", ["head 1"]),
    ("== guideway recordings", ["head 3"]),
    ("== the session's report", ["head 1"]),
]


def sanitize(text):
    """The user's own paths as the README shows them."""
    # demo.sh's run directory without XDG_RUNTIME_DIR is /tmp/guideway-UID
    runtime = os.environ.get("XDG_RUNTIME_DIR") or f"/tmp/guideway-{os.getuid()}"
    for value, shown in ((runtime, "/run/user/1000"), (os.environ.get("XDG_STATE_HOME"), "/home/you/.local/state"),
                         (os.environ.get("HOME"), "/home/you")):
        if value and value not in ("/", shown):
            text = text.replace(value.rstrip("/"), shown)
    return text


def rules_for(header):
    for prefix, rules in KEEP:
        if header.startswith(prefix):
            return rules
    return ["head 3"]


def abridge(transcript_lines):
    """The kept lines of the transcript, '...' for each run of lines left out."""
    sections, current = [], None
    for line in transcript_lines:
        if line.startswith("== ") or current is None:
            current = [line]
            sections.append(current)
        else:
            current.append(line)
    out = []
    for section in sections:
        rules = rules_for(section[0])
        heads = [int(r.split()[1]) for r in rules if r.startswith("head ")]
        tails = [int(r.split()[1]) for r in rules if r.startswith("tail ")]
        head = max(heads, default=1)  # the "== " line always stays
        tail = max(tails, default=0)
        kept = set(range(min(head, len(section)))) | set(range(max(0, len(section) - tail), len(section)))
        for rule in rules:
            if rule.startswith(("head ", "tail ")):
                continue
            words = rule.split(" ", 2)
            first, after = words[0] == "first", int(words[1]) if words[0] == "after" else 0
            pattern = re.compile(rule.split(" ", 1)[1] if first else words[2] if after or words[0] == "after" else rule)
            for i, line in enumerate(section):
                if pattern.search(line):
                    kept.update(range(i, min(len(section), i + after + 1)))
                    if first:
                        break
        skipped = False
        for i, line in enumerate(section):
            keep = i in kept or not line.strip()
            if keep:
                if skipped and (not out or out[-1] != "..."):
                    out.append("...")
                skipped = False
                if line.strip() or (out and out[-1].strip()):  # no two blank lines in a row
                    out.append(line)
            else:
                skipped = True
        if skipped and (not out or out[-1] != "..."):
            out.append("...")
    while out and not out[-1].strip():
        out.pop()
    return out


def block_from(transcript_text):
    lines = abridge(transcript_text.splitlines())
    return [INDENT + "```"] + [(INDENT + l).rstrip() for l in lines] + [INDENT + "```"]


def readme_block(readme_text):
    lines = readme_text.splitlines()
    try:
        b = next(i for i, l in enumerate(lines) if l.strip() == BEGIN)
        e = next(i for i, l in enumerate(lines) if l.strip() == END and i > b)
    except StopIteration:
        sys.exit(f"readme_demo: README.md has no block between {BEGIN!r} and {END!r}")
    return lines, b, e


def refresh(args):
    text = sanitize(demo_output(args))
    with open(TRANSCRIPT, "w") as f:
        f.write(text if text.endswith("\n") else text + "\n")
    with open(README) as f:
        lines, b, e = readme_block(f.read())
    new = lines[: b + 1] + block_from(text) + lines[e:]
    with open(README, "w") as f:
        f.write("\n".join(new) + "\n")
    print(f"readme_demo: {os.path.relpath(TRANSCRIPT, ROOT)} ({len(text.splitlines())} lines) and README.md's "
          f"block ({len(block_from(text)) - 2} lines) written", file=sys.stderr)


def check(_args):
    with open(TRANSCRIPT) as f:
        transcript = f.read()
    with open(README) as f:
        lines, b, e = readme_block(f.read())
    quoted = lines[b + 1 : e]
    expected = block_from(transcript)
    # Every quoted line is in the transcript, in order (the reader's promise) ...
    t = [l.rstrip() for l in transcript.splitlines()]
    pos = 0
    for q in quoted[1:-1]:
        body = q[len(INDENT):] if q.startswith(INDENT) else q
        if body == "...":
            continue
        try:
            pos = t.index(body.rstrip(), pos) + 1
        except ValueError:
            sys.exit(f"readme_demo: README.md quotes a line the demo's transcript does not have (in this order):\n"
                     f"  {body}\nrun scripts/readme_demo.py refresh")
    # ... and the block is the one the rules give (no hand edits that drift from them).
    if quoted != expected:
        for i, (a, c) in enumerate(zip(quoted + [""] * len(expected), expected + [""] * len(quoted))):
            if a != c:
                sys.exit(f"readme_demo: README.md's block differs from the transcript's abridgement at line {i + 1}:\n"
                         f"  README: {a!r}\n  rules:  {c!r}\nrun scripts/readme_demo.py refresh")
    print(f"readme_demo: README.md's {len(quoted) - 2} quoted lines are the transcript's, in order")


def shape(line):
    """A line up to its numbers: each run of digits (with its sign, point and exponent) becomes '#', the
    spaces that align a table's columns (their widths follow the numbers) one space, and a verdict against
    3 u (which a residual near it gets either way between runs) its kind."""
    out = " ".join(re.sub(r"[-+]?\d+(?:[.,]\d+)*(?:e[-+]?\d+)?", "#", line).split())
    # Verdicts against 3 u are statistics of the run too: a residual near 3 u falls either side between runs.
    out = re.sub(r"compensated(?: \(< # u\)|, NOT below # u)", "compensated (against # u)", out)
    return re.sub(r"^(still above # u after:).*", r"\1 ...", out)


def rerun(args):
    new_sections = {}  # "== " line (shape) -> the shapes of its lines; sections come in the demo's order
    order, current = [], None
    for line in sanitize(demo_output(args)).splitlines():
        if line.startswith("== ") or current is None:
            current = shape(line)
            order.append(current)
            new_sections.setdefault(current, [])
        new_sections[current].append(shape(line))
    with open(README) as f:
        lines, b, e = readme_block(f.read())
    at, section, compared = -1, "", 0
    for q in lines[b + 2 : e - 1]:
        body = q[len(INDENT):] if q.startswith(INDENT) else q
        if body.startswith("== "):
            section = body
            try:
                at = order.index(shape(body), at + 1)
            except ValueError:
                sys.exit(f"readme_demo: the new run has no section {body!r} after the ones before it")
            continue
        if body == "..." or not body.strip() or section.startswith("== building"):
            continue
        # Within a section, any order: a ranking of nearly equal errors may swap two neighbours. A list of
        # names (three or more after a colon) by its heading: which terms pass a 3 u test follows the noise.
        head, colon, rest = body.partition(": ")
        if colon and rest.count(", ") >= 2:
            found = any(l.startswith(shape(head) + ":") for l in new_sections[order[at]])
        else:
            found = shape(body) in new_sections[order[at]]
        if not found:
            sys.exit(f"readme_demo: the demo no longer prints a line the README quotes (up to numbers) in {section!r}:\n"
                     f"  {body}\nrun scripts/readme_demo.py refresh if the change is meant")
        compared += 1
    print(f"readme_demo: the new run prints all {compared} lines the README quotes, section by section, up to numbers")


def demo_output(args):
    if args.from_file:
        with open(args.from_file) as f:
            return f.read()
    print("readme_demo: running ./scripts/demo.sh " + " ".join(args.demo_args), file=sys.stderr)
    run = subprocess.run([os.path.join(ROOT, "scripts", "demo.sh"), *args.demo_args], cwd=ROOT,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if run.returncode != 0:
        sys.stderr.write(run.stdout[-4000:])
        sys.exit(f"readme_demo: demo.sh exited with {run.returncode}")
    return run.stdout


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("refresh", help="run the demo and rewrite the transcript and the README block")
    r.add_argument("--from", dest="from_file", help="the demo's saved output instead of a new run")
    r.add_argument("demo_args", nargs="*", help="arguments for demo.sh (after --)")
    sub.add_parser("check", help="the README block against the transcript")
    n = sub.add_parser("rerun", help="run the demo anew: the README's quoted lines, up to numbers, are in it")
    n.add_argument("--from", dest="from_file", help="the demo's saved output instead of a new run")
    n.add_argument("demo_args", nargs="*", help="arguments for demo.sh (after --)")
    args = p.parse_args()
    {"refresh": refresh, "check": check, "rerun": rerun}[args.cmd](args)


if __name__ == "__main__":
    main()
