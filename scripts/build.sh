#!/usr/bin/env bash
# Configures and builds one build tree. Usage: scripts/build.sh DIR [cmake options...] [-- targets...]
# Used by demo.sh and test.sh: a progress line at every tenth of the build, the errors if it fails.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=$1
shift
opts=()
targets=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; targets=("$@"); break; fi
  opts+=("$1"); shift
done
generator=()
if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
log="$dir.log"
mkdir -p "$dir"
if ! cmake -S . -B "$dir" "${generator[@]}" "${opts[@]}" >"$log" 2>&1; then
  cat "$log"; echo "build: cmake configure of $dir failed (log above, also in $log)" >&2; exit 1
fi
jobs=${GUIDEWAY_BUILD_JOBS:-$(nproc)}
# A line at every tenth of the build (ninja's [N/M], make's [ P%]), so a long first build is never
# silent: GUIDEWAY_BUILD_QUIET=1 leaves them out.
progress() {
  if [ "${GUIDEWAY_BUILD_QUIET:-0}" = 1 ]; then cat >/dev/null; return; fi
  awk -v dir="$dir" -v start="$(date +%s)" '
    { p = -1 }
    match($0, /^\[[0-9]+\/[0-9]+\]/) { split(substr($0, 2, RLENGTH - 2), nm, "/"); if (nm[2] > 0) p = int(100 * nm[1] / nm[2]); n = nm[1]; m = nm[2] }
    match($0, /^\[ *[0-9]+%\]/) { p = substr($0, 2, RLENGTH - 3) + 0; n = ""; m = "" }
    p >= 0 && int(p / 10) > shown {
      shown = int(p / 10)
      printf "   build %s: %3d %%%s, %d s\n", dir, p, (m != "" ? " (" n "/" m " steps)" : ""), systime() - start
      fflush()
    }
    BEGIN { shown = 0 }'
}
set +e
cmake --build "$dir" -j "$jobs" ${targets:+--target "${targets[@]}"} 2>&1 | tee -a "$log" | progress
status=${PIPESTATUS[0]}
set -e
if [ "$status" -ne 0 ]; then
  grep -E "error|Error|FAILED" "$log" | head -40; echo "build: $dir failed (full log in $log)" >&2; exit 1
fi
