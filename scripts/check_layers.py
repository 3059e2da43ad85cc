#!/usr/bin/env python3
"""Fails when a library includes a header of a layer above it (docs/architecture.md, "Layers").

Usage: scripts/check_layers.py [ROOT]   (default: the repository this script is in)
Prints one line per offending include, file:line first, and exits 1; exits 0 when every include
points down or sideways into an allowed layer. Only project includes ("layer/...") are checked.
"""
import pathlib
import re
import sys

# Each top-level folder and the folders its code may include besides itself. Keep in step with
# docs/architecture.md.
ALLOWED = {
    "core": set(),
    "dsp": {"core"},
    "formats": {"core"},
    "results": {"core"},
    "models": {"core", "dsp", "formats", "results"},
    "drivers": {"core", "formats"},
    "plant": {"core"},
    "report": {"core", "dsp", "formats", "results", "models"},
    "simulators": {"core", "dsp", "formats", "results", "models", "drivers"},
    "sessions": {"core", "dsp", "formats", "results", "models", "drivers", "report"},
    "fleet": {"core", "formats", "results", "report", "plant"},
    "daemon": {"core", "dsp", "formats", "results", "models", "drivers", "report", "sessions", "plant"},
    "cli": {"core", "dsp", "formats", "results", "models", "drivers", "report", "simulators", "sessions", "plant",
            "fleet"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')


def violations(root: pathlib.Path):
    for layer, allowed in ALLOWED.items():
        base = root / layer
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*")):
            if path.suffix not in (".cpp", ".hpp", ".h", ".inc") or not path.is_file():
                continue
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target = m.group(1)
                if target == layer or target in allowed or target not in ALLOWED:
                    continue
                yield (f"{path.relative_to(root)}:{number}: {layer}/ includes {target}/ "
                       f"({line.strip()}); {layer}/ may include only "
                       f"{', '.join(sorted(allowed)) or 'itself'}")


def main() -> int:
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
    found = sorted(violations(root))
    for v in found:
        print(v)
    if found:
        print(f"{len(found)} include(s) point up a layer", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
