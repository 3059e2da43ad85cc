#!/usr/bin/env bash
# LinuxCNC in the loop, headless, in one command (docs/linuxcnc.md): LinuxCNC (Debian's linuxcnc-uspace,
# the virtual machine's configuration in linuxcnc/sim/, as an unprivileged user) runs the ballbar test
# `guideway program dbb` writes, the virtual machine moves as LinuxCNC commands it (through
# guideway-linuxcnc-bridge), guidewayd measures and identifies it, `guideway compensate dbb` and `guideway
# linuxcnc offsets` write the correction, LinuxCNC restarts with it and runs the same program again. The last
# line: "LinuxCNC loop: G before X µm, after Y µm (tables loaded by LinuxCNC)".
#
# usage: scripts/linuxcnc_demo.sh [--keep] [--feed-mm-per-min F] [--radius-mm R] [--machine FILE]
#   (from the source: installs what is missing with scripts/setup.sh and builds build/; installed from the
#   Debian package: /usr/share/guideway/linuxcnc/linuxcnc_demo.sh runs the installed programs)
# Takes about 5 minutes at the standard test's 1000 mm/min (two runs of two circles of 450 deg at r = 100 mm),
# with a line of progress every few seconds. Exits 77 when LinuxCNC cannot run here (the reason printed).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
args=()
while [ $# -gt 0 ]; do
  case $1 in
    --keep) args+=(--keep --work "${TMPDIR:-/tmp}/guideway-linuxcnc-demo-$(date +%Y%m%dT%H%M%S)") ;;
    --feed-mm-per-min|--radius-mm|--machine) args+=("$1" "${2:?$1 needs a value}"); shift ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "usage: $0 [--keep] [--feed-mm-per-min F] [--radius-mm R] [--machine FILE]" >&2; exit 2 ;;
  esac
  shift
done
if [ -f "$here/linuxcnc_loop.py" ] && [ -d "$here/../linuxcnc" ] && [ -f "$here/../CMakeLists.txt" ]; then
  # The source tree.
  cd "$here/.."
  ./scripts/setup.sh
  echo "== building (first time: a few minutes)"
  scripts/build.sh build -DCMAKE_BUILD_TYPE=Release -- guideway_runtime
  exec python3 scripts/linuxcnc_loop.py --bin-dir build "${args[@]}"
fi
# The installed package: the loop, its LinuxCNC files and the programs on PATH.
exec python3 "$here/linuxcnc_loop.py" --share-dir "$here" "${args[@]}"
