#!/usr/bin/env python3
"""Fails when a library includes a header of a layer above it (docs/architecture.md, "Layers").

Usage: scripts/check_layers.py [--arrows] [ROOT]   (default: the repository this script is in)
Prints one line per offending include, file:line first, and exits 1; exits 0 when every include
points down or sideways into an allowed layer. Only project includes ("layer/...") are checked.
--arrows: the arrows the tree has (each folder, the folders its includes reach, with how many includes)
and each folder's floor (core 0; one above the highest floor it reaches), then the check as above.
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
    # Not report/: whoever builds a session's report (the daemon) hands it what the session identified.
    "sessions": {"core", "dsp", "formats", "results", "models", "drivers"},
    "fleet": {"core", "formats", "results", "report", "plant"},
    "daemon": {"core", "dsp", "formats", "results", "models", "drivers", "report", "sessions", "plant"},
    "cli": {"core", "dsp", "formats", "results", "models", "drivers", "report", "simulators", "sessions", "plant",
            "fleet"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')


def includes(root: pathlib.Path):
    """(layer, path, line number, line, target layer) of every include of another layer."""
    for layer in ALLOWED:
        base = root / layer
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*")):
            if path.suffix not in (".cpp", ".hpp", ".h", ".inc") or not path.is_file():
                continue
            for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                m = INCLUDE.match(line)
                if m and m.group(1) != layer and m.group(1) in ALLOWED:
                    yield layer, path, number, line, m.group(1)


def violations(root: pathlib.Path):
    for layer, path, number, line, target in includes(root):
        allowed = ALLOWED[layer]
        if target in allowed:
            continue
        yield (f"{path.relative_to(root)}:{number}: {layer}/ includes {target}/ "
               f"({line.strip()}); {layer}/ may include only "
               f"{', '.join(sorted(allowed)) or 'itself'}")


def arrows(root: pathlib.Path):
    """{layer: {target: number of includes}} as the tree has them."""
    found = {layer: {} for layer in ALLOWED}
    for layer, _, _, _, target in includes(root):
        found[layer][target] = found[layer].get(target, 0) + 1
    return found


def floors(found):
    """{layer: floor}: 0 for a folder that includes no other, else one above the highest it includes
    (a cycle, which the check refuses anyway, is cut where it closes)."""
    floor = {}

    def of(layer, seen=()):
        if layer not in floor:
            reach = [of(t, seen + (layer,)) for t in found[layer] if t not in seen + (layer,)]
            floor[layer] = 1 + max(reach) if reach else 0
        return floor[layer]

    for layer in found:
        of(layer)
    return floor


def main() -> int:
    args = sys.argv[1:]
    show_arrows = "--arrows" in args
    args = [a for a in args if a != "--arrows"]
    root = pathlib.Path(args[0] if args else pathlib.Path(__file__).resolve().parent.parent)
    if show_arrows:
        found = arrows(root)
        floor = floors(found)
        for layer in sorted(found, key=lambda name: (floor[name], name)):
            reach = ", ".join(f"{t} {n}" for t, n in sorted(found[layer].items(), key=lambda item: (floor[item[0]], item[0])))
            print(f"floor {floor[layer]}  {layer}/ -> {reach or 'nothing'}")
        print(f"{sum(len(t) for t in found.values())} arrows, {1 + max(floor.values())} floors")
    found = sorted(violations(root))
    for v in found:
        print(v)
    if found:
        print(f"{len(found)} include(s) point up a layer", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
