#!/usr/bin/env python3
"""Lists the longest C++ functions, lambdas or classes of the tree, or fails when one (or a file) is over a bound.

Usage:
  scripts/function_lengths.py [--top N] [--lambdas | --classes] [DIR ...]   the N longest (default 20)
  scripts/function_lengths.py [--max-lines N] [--max-lambda-lines M] [--max-class-lines C]
                              [--max-file-lines F] DIR ...
                                                  exits 1 naming each function (lambda, class, file) longer
A length is the lines from the function's name to its closing brace. A lambda is measured on its own
and also counts in the function around it. A class (struct, union) is its definition, from `class` to
its closing brace, plus its members defined outside it (`Name::member` in the class's own file, or in
the folder of the header that defines it): what a reader must take in to know it. Comments and string
literals are read as blanks, so a brace in them does not count. No compiler needed: a small scanner of
braces and parentheses, good for this code base's style (docs/architecture.md "Where a new thing goes":
the bounds on cli/, models/ and report/).
"""
import argparse
import pathlib
import re
import sys

SOURCE_SUFFIXES = (".cpp", ".hpp", ".h", ".inc")
SCOPE_KEYWORDS = re.compile(r"^(template\s*<.*>\s*)?(namespace|class|struct|union|enum|extern)\b", re.S)
# A class head once its template parameters are gone: its keyword and its (qualified) name.
CLASS_HEAD = re.compile(r"(class|struct|union)\s+(?:alignas\s*\([^)]*\)\s*)?(?:\[\[[^\]]*\]\]\s*)?([A-Za-z_][\w:]*)")
IDENT = re.compile(r"[A-Za-z_~][A-Za-z_0-9]*(?:::[A-Za-z_~][A-Za-z_0-9]*)*$")


def blank_comments_and_strings(text):
    """The text with comments, string and character literals replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append('""' + re.sub(r"[^\n]", " ", text[i + 2:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (j - i - 1) + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching(text):
    """Maps each opening ( [ { to its closing partner's index, and back."""
    pairs, stack = {}, []
    for i, c in enumerate(text):
        if c in "([{":
            stack.append(i)
        elif c in ")]}" and stack:
            j = stack.pop()
            pairs[j], pairs[i] = i, j
    return pairs


def previous_nonspace(text, i):
    i -= 1
    while i >= 0 and text[i].isspace():
        i -= 1
    return i


LAMBDA_TAIL = re.compile(r"([\])])\s*(?:(?:mutable|noexcept|constexpr)\s*)*(?:->\s*[\w:<>,&*\s]+?)?\s*$")


def lambda_before(text, pairs, brace):
    """True when the { at `brace` opens a lambda's body: [..] {, [..](..) {, with specifiers between."""
    lo = max(0, brace - 300)
    m = LAMBDA_TAIL.search(text[lo:brace])
    if not m:
        return False
    at = lo + m.start(1)
    if text[at] == "]":
        return True
    k = previous_nonspace(text, pairs.get(at, at))
    return at in pairs and k >= 0 and text[k] == "]"


def function_name(header):
    """The name before the header's first top-level parenthesis ("" when there is none)."""
    depth = 0
    for i, c in enumerate(header):
        if c == "<":
            depth += 1
        elif c == ">" and depth:
            depth -= 1
        elif c == "(" and depth == 0:
            head = header[:i].rstrip()
            m = re.search(r"(operator\s*(?:\(\)|\[\]|[^\s\w(]+|\w+)|[A-Za-z_~][\w]*(?:::[A-Za-z_~][\w]*)*)$", head)
            return m.group(1) if m else ""
    return ""


def scan(path, text):
    """(kind, name, first line, last line) of every function and lambda in one file."""
    code = blank_comments_and_strings(text)
    pairs = matching(code)
    line_of = [0] * (len(code) + 1)
    line = 1
    for i, c in enumerate(code):
        line_of[i] = line
        if c == "\n":
            line += 1
    found = []

    def walk(start, end, qualifier):
        """Scope [start, end): a namespace or class body; finds function definitions in it."""
        stmt = start
        i = start
        while i < end:
            c = code[i]
            if c in "(":
                i = pairs.get(i, i) + 1
                continue
            if c in ";":
                stmt = i + 1
            elif c == "}":
                stmt = i + 1
            elif c == "{":
                close = pairs.get(i, end - 1)
                header = code[stmt:i].strip()
                header = re.sub(r"^(public|private|protected)\s*:\s*", "", header)
                header = re.sub(r"^\s*#.*$", "", header, flags=re.M).strip()
                paren = header.find("(")
                top = re.sub(r"\([^()]*\)", "()", header)
                if SCOPE_KEYWORDS.match(header):
                    decl = re.sub(r"^template\s*<.*?>\s*(?=(?:class|struct|union)\b)", "", header, flags=re.S)
                    m = CLASS_HEAD.match(decl)
                    if m:
                        qualified = (qualifier + "::" + m.group(2)).lstrip(":")
                        names = [x.start() for x in re.finditer(r"\b" + re.escape(m.group(2)) + r"\b", code[stmt:i])]
                        heads = [x.start() for x in re.finditer(r"\b(?:class|struct|union)\b", code[stmt:i])
                                 if not names or x.start() < names[-1]]
                        found.append(("class", qualified, line_of[stmt + (heads[-1] if heads else 0)], line_of[close]))
                    walk(i + 1, close, (qualifier + "::" + m.group(2)) if m else qualifier)
                    stmt = close + 1
                    i = close + 1
                    continue
                if paren >= 0 and "=" not in top.replace("operator=", "").replace("==", "") and not header.endswith(","):
                    name = function_name(header)
                    body = i
                    # A constructor's initialiser list: its member{...} braces come before the body.
                    p = code.find("(", stmt, i)
                    if re.match(r"\s*(noexcept\b\s*)?:(?!:)", code[pairs.get(p, p) + 1:i] if p >= 0 else ""):
                        while (code[previous_nonspace(code, body)].isalnum() or
                               code[previous_nonspace(code, body)] in "_>"):
                            nxt = code.find("{", pairs.get(body, body) + 1, end)
                            if nxt < 0:
                                break
                            body = nxt
                    close = pairs.get(body, end - 1)
                    name_at = stmt + code[stmt:i].find(name.split("::")[-1]) if name else i
                    qualified = name if "::" in name or not qualifier else qualifier.lstrip(":") + "::" + name
                    found.append(("function", qualified or "?", line_of[name_at], line_of[close]))
                    lambdas(body + 1, close, qualified or "?")
                    stmt = close + 1
                    i = close + 1
                    continue
                stmt = close + 1  # data: an initialiser, an enum
                i = close + 1
                continue
            i += 1

    def lambdas(start, end, owner):
        for i in range(start, end):
            if code[i] == "{" and lambda_before(code, pairs, i):
                first = previous_nonspace(code, i)
                found.append(("lambda", "lambda in " + owner, line_of[first], line_of[pairs.get(i, end)]))

    walk(0, len(code), "")
    return found


def source_files(roots):
    for root in roots:
        base = pathlib.Path(root)
        yield from [base] if base.is_file() else sorted(p for p in base.rglob("*") if p.suffix in SOURCE_SUFFIXES)


def measure(roots):
    """(lines, kind, name, where) of every function, lambda and class (a class with its members defined
    outside it), and (lines, "file", path, path) of every file."""
    rows, found = [], []
    for path in source_files(roots):
        text = path.read_text(errors="replace")
        rows.append((text.count("\n") + (0 if text.endswith("\n") or not text else 1), "file", str(path), str(path)))
        for kind, name, first, last in scan(path, text):
            found.append((path, kind, name, first, last))
            if kind != "class":
                rows.append((last - first + 1, kind, name, f"{path}:{first}"))
    # A class defined in a source file is that file's (an anonymous namespace's); one in a header, its folder's.
    classes = {}
    for path, kind, name, first, last in found:
        if kind == "class":
            key = (path, name) if path.suffix == ".cpp" else (path.parent, name)
            if key not in classes:
                classes[key] = {"lines": 0, "where": f"{path}:{first}", "spans": []}
            classes[key]["lines"] += last - first + 1
            classes[key]["spans"].append((path, first, last))
    for path, kind, name, first, last in found:
        if kind != "function" or "::" not in name:
            continue
        owner = name.rsplit("::", 1)[0]
        c = classes.get((path, owner)) or classes.get((path.parent, owner))
        if c and not any(p == path and a <= first <= b for p, a, b in c["spans"]):
            c["lines"] += last - first + 1
    for (_, name), c in classes.items():
        rows.append((c["lines"], "class", name, c["where"]))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="*", default=["."])
    ap.add_argument("--top", type=int, default=20)
    ap.add_argument("--lambdas", action="store_true", help="list lambdas too")
    ap.add_argument("--classes", action="store_true", help="list classes (with their members defined outside)")
    ap.add_argument("--max-lines", type=int, help="fail on a function longer than this")
    ap.add_argument("--max-lambda-lines", type=int, help="fail on a lambda longer than this")
    ap.add_argument("--max-class-lines", type=int, help="fail on a class longer than this")
    ap.add_argument("--max-file-lines", type=int, help="fail on a file longer than this")
    args = ap.parse_args()
    rows = measure(args.dirs)
    bounds = {"function": args.max_lines, "lambda": args.max_lambda_lines, "class": args.max_class_lines,
              "file": args.max_file_lines}
    if any(b is not None for b in bounds.values()):
        over = [r for r in rows if bounds[r[1]] is not None and r[0] > bounds[r[1]]]
        for n, kind, name, where in sorted(over, reverse=True):
            print(f"{where}: file is {n} lines" if kind == "file" else f"{where}: {kind} {name} is {n} lines")
        return 1 if over else 0
    if args.classes:
        for n, kind, name, where in sorted((r for r in rows if r[1] == "class"), reverse=True)[:args.top]:
            print(f"{n:5d}  {kind:8s}  {name}  {where}")
        return 0
    shown = sorted((r for r in rows if (args.lambdas and r[1] == "lambda") or r[1] == "function"),
                   reverse=True)[:args.top]
    for n, kind, name, where in shown:
        print(f"{n:5d}  {kind:8s}  {name}  {where}")
    functions = sorted(r[0] for r in rows if r[1] == "function")
    if functions:
        print(f"{len(functions)} functions: median {functions[len(functions) // 2]} lines, "
              f"p90 {functions[int(len(functions) * 0.9)]}, longest {functions[-1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
