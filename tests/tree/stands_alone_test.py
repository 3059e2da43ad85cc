#!/usr/bin/python3
"""The project stands alone: no file of it (code, tests, scripts, docs, configuration) names the directory
beside the checkout that the brief's material lives in, so a fresh clone builds and tests by itself. The
real data the tests need is copied into tests/data with its provenance.
Usage: stands_alone_test.py SOURCE_DIR"""
import os
import subprocess
import sys

SOURCE = sys.argv[1] if len(sys.argv) > 1 else "."
# Built from pieces so that this file does not name it.
PATTERNS = [".." + "/shared", "/work" + "/shared"]


def project_files():
    try:
        out = subprocess.run(["git", "-C", SOURCE, "ls-files"], capture_output=True, text=True, check=True).stdout
        return [os.path.join(SOURCE, f) for f in out.splitlines()]
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: every file but the build trees
        files = []
        for root, dirs, names in os.walk(SOURCE):
            dirs[:] = [d for d in dirs if not d.startswith("build") and d != ".git"]
            files += [os.path.join(root, n) for n in names]
        return files


def main():
    bad = []
    for path in project_files():
        if not os.path.isfile(path):
            continue
        try:
            with open(path, encoding="utf-8", errors="strict") as f:
                for number, line in enumerate(f, 1):
                    if any(p in line for p in PATTERNS):
                        bad.append(f"{os.path.relpath(path, SOURCE)}:{number}: {line.strip()[:120]}")
        except UnicodeDecodeError:
            continue  # binary (the X3P sample)
    for b in bad:
        print(b)
    print(f"{len(bad)} line(s) name the directory outside the project" if bad else "the project stands alone")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
