#!/usr/bin/env bash
# Configures and builds one build tree. Usage: scripts/build.sh DIR [cmake options...] [-- targets...]
# Used by demo.sh and test.sh; quiet unless something fails. With ccache installed the build goes through
# it (CMakeLists.txt, GUIDEWAY_USE_CCACHE): paths below the checkout are hashed relative to it
# (CCACHE_BASEDIR, unless already set), so every build tree of it, and every other checkout under the
# same base, reuses the same objects.
set -euo pipefail
cd "$(dirname "$0")/.."
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(pwd)}
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
if ! cmake --build "$dir" -j "$jobs" ${targets:+--target "${targets[@]}"} >>"$log" 2>&1; then
  grep -E "error|Error|FAILED" "$log" | head -40; echo "build: $dir failed (full log in $log)" >&2; exit 1
fi
