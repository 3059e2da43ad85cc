#!/usr/bin/env bash
# dbb_bench of the working tree against the same benchmark with the identification sources as they
# were at an older commit (models/dbb/identify.cpp and, from the commit that split it, its parts
# fit_points, lai_fit, diagnostics and diagnostics_search, and models/common/*.cpp, or the files listed in
# $DBB_COMPARE_FILES; everything else from the working tree), run alternately in one
# session so that both see the same machine load. Prints the medians of wall and CPU time.
# Usage: bench/dbb_compare.sh BUILD_DIR [COMMIT (default a50fd25)] [ROUNDS (default 3)]
# BUILD_DIR: a Release build with -DGUIDEWAY_BUILD_BENCH=ON where dbb_bench has been built.
set -euo pipefail
build=$(cd "$1" && pwd)
commit=${2:-a50fd25}
rounds=${3:-3}
src=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
identify_parts='^models/dbb/(identify|fit_points|lai_fit|diagnostics|diagnostics_search)\.cpp$'
files=${DBB_COMPARE_FILES:-$(git -C "$src" ls-tree --name-only "$commit" models/dbb/ models/common/ |
  grep -E "$identify_parts|^models/common/.*\.cpp$")}
# The old files are compiled against the old tree's headers (a changed signature must not send the
# old code to the new definition).
mkdir "$tmp/old_tree"
git -C "$src" archive "$commit" | tar -x -C "$tmp/old_tree"
old_objects=()
for f in $files; do
  o="$tmp/old_$(basename "$f" .cpp)"
  c++ -std=c++20 -O3 -DNDEBUG -I"$tmp/old_tree" -isystem /usr/include/eigen3 -c "$tmp/old_tree/$f" -o "$o.o"
  old_objects+=("$o.o")
done
# The old objects come first, so the archives' versions of them are never pulled in.
c++ -O3 "$build/bench/CMakeFiles/dbb_bench.dir/dbb_bench.cpp.o" "${old_objects[@]}" -o "$tmp/dbb_bench_old" \
  "$build/simulators/machine/libguideway_dbb_sim.a" "$build/models/dbb/libguideway_model_dbb.a" \
  "$build/models/common/libguideway_models_common.a" "$build/simulators/machine/libguideway_machine.a" \
  "$build/formats/libguideway_formats.a" "$build/results/libguideway_results.a" "$build/core/libguideway_core.a" \
  -lbenchmark -ltomlplusplus
for i in $(seq 1 "$rounds"); do
  "$tmp/dbb_bench_old" --benchmark_format=json >"$tmp/old_$i.json" 2>/dev/null
  "$build/bench/dbb_bench" --benchmark_format=json >"$tmp/new_$i.json" 2>/dev/null
done
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/python3 - "$tmp" "$commit" <<'EOF'
import glob, json, statistics, sys
tmp, commit = sys.argv[1], sys.argv[2]
for tag, label in (("old", f"sources at {commit}"), ("new", "working tree")):
    wall, cpu = [], []
    for f in sorted(glob.glob(f"{tmp}/{tag}_*.json")):
        for b in json.load(open(f))["benchmarks"]:
            if b.get("aggregate_name") == "median":
                wall.append(b["real_time"])
                cpu.append(b["cpu_time"])
    print(f"{label:32s} median of {len(cpu)} medians: wall {statistics.median(wall):6.2f} ms, CPU {statistics.median(cpu):6.2f} ms"
          f"  (CPU per round: {', '.join(f'{c:.1f}' for c in cpu)})")
EOF
