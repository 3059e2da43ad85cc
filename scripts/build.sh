#!/usr/bin/env bash
# Configures and builds one build tree. Usage: scripts/build.sh DIR [cmake options...] [-- targets...]
# Used by demo.sh and test.sh: a progress line at every tenth of the build, the errors if it fails.
# With ccache installed the build goes through it (CMakeLists.txt, GUIDEWAY_USE_CCACHE): paths below the checkout are hashed relative to it
# (CCACHE_BASEDIR, unless already set), so every build tree of it, and every other checkout under the
# same base, reuses the same objects.
set -euo pipefail
cd "$(dirname "$0")/.."
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(pwd)}
# The precompiled headers (the CLI's, the tests'): ccache caches a file built with one only with this
# sloppiness (its manual, "Precompiled headers"), else it compiles every such file anew.
export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}
dir=$1
shift
opts=()
targets=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; targets=("$@"); break; fi
  opts+=("$1"); shift
done
cached() {  # NAME: its value in the tree's cache, if any
  [ -f "$dir/CMakeCache.txt" ] || return 0
  sed -n "s/^$1:[A-Z]*=//p" "$dir/CMakeCache.txt" | head -1
}
# A tree configured with another compiler than the one asked for: CMake would delete its cache and
# configure again without the options given here (a tree asked for ASan came out a plain
# RelWithDebInfo build, and its "ASan" tests passed): start the tree's configuration anew instead.
for opt in "${opts[@]}"; do
  case $opt in
    -DCMAKE_C_COMPILER=* | -DCMAKE_CXX_COMPILER=*)
      name=${opt#-D}; name=${name%%=*}; want=${opt#*=}; have=$(cached "$name")
      if [ -n "$have" ] && [ "$(readlink -f "$(command -v "$have")")" != "$(readlink -f "$(command -v "$want")")" ]; then
        echo "build: $dir was configured with $name=$have, not $want: configuring it anew"
        rm -rf "$dir/CMakeCache.txt" "$dir/CMakeFiles"
      fi ;;
  esac
done
generator=()
if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
log="$dir.log"
mkdir -p "$dir"
if ! cmake -S . -B "$dir" "${generator[@]}" "${opts[@]}" >"$log" 2>&1; then
  cat "$log"; echo "build: cmake configure of $dir failed (log above, also in $log)" >&2; exit 1
fi
# Every option given is what the tree now has (a tree that is not what its stage says would test
# something else under that stage's name).
for opt in "${opts[@]}"; do
  case $opt in
    -D*=*)
      name=${opt#-D}; name=${name%%=*}; name=${name%%:*}; want=${opt#*=}
      case $name in CMAKE_C_COMPILER | CMAKE_CXX_COMPILER) continue ;; esac
      if [ "$(cached "$name")" != "$want" ]; then
        echo "build: $dir has $name='$(cached "$name")' after configuring, not '$want' (log: $log)" >&2; exit 1
      fi ;;
  esac
done
jobs=${GUIDEWAY_BUILD_JOBS:-$(nproc)}
# A line at every tenth of the build (ninja's [N/M], make's [ P%]), and one at least every 30 s between
# them ("still at it" while no step ends: a long compile or link; the last tenth of a first build is a few
# long steps), so a long build is never silent: GUIDEWAY_BUILD_QUIET=1 leaves them out.
progress() {
  if [ "${GUIDEWAY_BUILD_QUIET:-0}" = 1 ]; then cat >/dev/null; return; fi
  local line percent=0 steps="" shown=0 start=$SECONDS said=$SECONDS re_ninja='^\[([0-9]+)/([0-9]+)\]' re_make='^\[ *([0-9]+)%\]'
  while true; do  # bash, not awk: mawk reads a pipe in blocks and would print them late
    local rc=0
    IFS= read -r -t 5 line || rc=$?
    if [ $rc -ne 0 ]; then
      [ $rc -gt 128 ] || break  # the end of the build's output; else 5 s without a line
      if [ $((SECONDS - said)) -ge 30 ]; then
        said=$SECONDS
        printf '   build %s: %3d %%%s, %d s (still at it)\n' "$dir" "$percent" "$steps" $((SECONDS - start))
      fi
      continue
    fi
    if [[ $line =~ $re_ninja ]] && [ "${BASH_REMATCH[2]}" -gt 0 ]; then
      percent=$((100 * BASH_REMATCH[1] / BASH_REMATCH[2])); steps=" (${BASH_REMATCH[1]}/${BASH_REMATCH[2]} steps)"
    elif [[ $line =~ $re_make ]]; then
      percent=${BASH_REMATCH[1]}; steps=""
    else
      continue
    fi
    if [ $((percent / 10)) -gt $shown ]; then
      shown=$((percent / 10))
      said=$SECONDS
      printf '   build %s: %3d %%%s, %d s\n' "$dir" "$percent" "$steps" $((SECONDS - start))
    elif [ $((SECONDS - said)) -ge 30 ]; then  # steps end, slowly, within one tenth
      said=$SECONDS
      printf '   build %s: %3d %%%s, %d s\n' "$dir" "$percent" "$steps" $((SECONDS - start))
    fi
  done
}
set +e
cmake --build "$dir" -j "$jobs" ${targets:+--target "${targets[@]}"} 2>&1 | tee -a "$log" | progress
status=${PIPESTATUS[0]}
set -e
if [ "$status" -ne 0 ]; then
  grep -E "error|Error|FAILED" "$log" | head -40; echo "build: $dir failed (full log in $log)" >&2; exit 1
fi
