#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, then
#   1. a Release build (as packagers build): every test but the long variants (label `slow`);
#   2. an ASan+UBSan build: every test except `slow` and `peer` (a peer's program run against our files);
#   3. a TSan build of the threaded code: the tests labelled `tsan` (ring stress, daemon threads).
# The long variants (statistics over many seeds, the demo and the three-plane session run anew) are the
# stage `slow`, in the Release build: CI runs it after these (.ci/run).
# While one stage's tests run, the next stage's build runs beside them at idle priority (SCHED_IDLE: it
# takes only what the tests leave of the CPUs; most of them wait on sockets and emulated machines), so
# that its stage starts with its build done or nearly (not done when they end, it goes on at normal
# priority: beside other busy processes it would never finish). Each stage's tests are checked against their
# timeouts (scripts/test_margin.py: over a third of its timeout warns, over half fails the stage).
# GUIDEWAY_TEST_STAGES="main asan tsan" selects stages (and `slow`); GUIDEWAY_TEST_LABEL=slow adds the
# long variants to the Release and ASan stages.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
stages=${GUIDEWAY_TEST_STAGES:-main asan tsan}
jobs=$(nproc)
passed=0
failed=0
start=$(date +%s)

skipped=0
cases_run=0
cases_skipped=0

# Runs ctest, then says what ran, passed, failed and was skipped (with the reasons), from its JUnit file
# (scripts/test_summary.py): ctest itself counts a test whose cases GoogleTest or unittest skipped as
# passed, and a whole test skipped for a missing tool is easy to miss in its list.
run_ctest() {  # dir, ctest args...
  local dir=$1; shift
  local junit
  junit="$(cd "$dir" && pwd)/Testing/junit.xml"
  rm -f "$junit"
  # Each test's line as it ends (a stage's tests run for minutes: its progress shows).
  set +e
  ctest --test-dir "$dir" --output-on-failure -j "$jobs" --output-junit "$junit" \
    --test-output-size-passed 50000000 "$@" 2>&1 | grep --line-buffered -vE '^\s*(Start|Test project)'
  local rc=${PIPESTATUS[0]}
  set -e
  if [ -f "$junit" ]; then
    local summary counts
    summary=$(python3 scripts/test_summary.py "$stage" "$junit")
    echo "$summary" | grep -v '^COUNTS '
    counts=($(echo "$summary" | grep '^COUNTS ' | cut -d' ' -f2-))
    passed=$((passed + counts[0])); failed=$((failed + counts[1])); skipped=$((skipped + counts[2]))
    cases_run=$((cases_run + counts[3])); cases_skipped=$((cases_skipped + counts[4]))
    # Each test's time against its timeout: over a third warns, over half fails the stage.
    if ! python3 scripts/test_margin.py "$stage" "$dir" "$junit"; then failed=$((failed + 1)); fi
  elif [ $rc -ne 0 ]; then
    failed=$((failed + 1))
  fi
  return 0
}

# Each stage's build: its tree, its options, and the targets it tests (none named: everything).
build_dir() {
  case $1 in main | slow) echo build ;; asan) echo build-asan ;; tsan) echo build-tsan ;; esac
}
build_stage() {  # stage
  # The sanitizer stages compile with clang when it is installed (setup.sh installs it): the same tree's
  # files take 20-45 % less CPU than with GCC (measured file by file; the test programs at -O0 most), and
  # a second compiler's warnings and UBSan checks come with it. GUIDEWAY_SANITIZER_CXX=g++ keeps GCC.
  local cxx=${GUIDEWAY_SANITIZER_CXX:-clang++} cc
  case $cxx in *clang++*) cc=${cxx/clang++/clang} ;; *g++*) cc=${cxx/g++/gcc} ;; *) cc=cc ;; esac
  local compilers=()
  if command -v "$cxx" >/dev/null && command -v "$cc" >/dev/null; then
    compilers=(-DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx")
  fi
  case $1 in
    main | slow) scripts/build.sh build -DCMAKE_BUILD_TYPE=Release -DGUIDEWAY_BUILD_TESTS=ON -DGUIDEWAY_BUILD_BENCH=ON ;;
    # -g1 (line tables), as CMakeLists.txt's RelWithDebInfo default: sanitizer reports need only file:line.
    # The thin code at -O0 (GUIDEWAY_THIN_CODE_FLAGS: test programs, mains, the CLI and the wiring
    # libraries; CMakeLists.txt): half their compile time; the numeric libraries under test keep -O1.
    asan) scripts/build.sh build-asan "${compilers[@]}" -DCMAKE_BUILD_TYPE=Debug -DGUIDEWAY_SANITIZE=address -DGUIDEWAY_BUILD_BENCH=OFF \
            -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DGUIDEWAY_THIN_CODE_FLAGS=-O0 ;;
    tsan) scripts/build.sh build-tsan "${compilers[@]}" -DCMAKE_BUILD_TYPE=Debug -DGUIDEWAY_SANITIZE=thread -DGUIDEWAY_BUILD_BENCH=OFF \
            -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DGUIDEWAY_THIN_CODE_FLAGS=-O0 -- guideway_tsan_tests ;;
    *) echo "unknown stage $1" >&2; exit 2 ;;
  esac
}

# The next stage's build, started beside this stage's tests at idle priority; its output in DIR.bg.log.
bg_stage=""
bg_pid=""
bg_start=0
start_background_build() {  # stage
  local dir idle=()
  dir=$(build_dir "$1")
  if command -v chrt >/dev/null && chrt --idle 0 true 2>/dev/null; then idle=(chrt --idle 0); else idle=(nice -n 19); fi
  bg_stage=$1
  bg_start=$(date +%s)
  # Its own session, so that an early exit stops its compilers too (the trap below).
  GUIDEWAY_BUILD_QUIET=1 setsid "${idle[@]}" bash -c "$(declare -f build_stage); build_stage $1" >"$dir.bg.log" 2>&1 &
  bg_pid=$!
  echo "   ($1 build started beside these tests at idle priority: $dir.bg.log)"
}
# The background build of `stage` done, or finished here; false when it failed.
finish_background_build() {  # stage
  [ "$bg_stage" = "$1" ] || return 0
  local dir rc=0
  dir=$(build_dir "$1")
  if kill -0 "$bg_pid" 2>/dev/null; then
    # Nothing of ours runs beside it now, and at idle priority other busy processes (two CPU hogs) would
    # starve it for good (a fresh clone's ASan configure beside them: 29 min without end). An unprivileged
    # user may not lift SCHED_IDLE, so it is stopped and continued here: ninja keeps what it finished.
    echo "   build $dir: not done beside the tests; continued here at normal priority"
    kill -- -"$bg_pid" 2>/dev/null || true
    wait "$bg_pid" 2>/dev/null || true
    bg_stage=""
    build_stage "$1" || { echo "build: $dir failed (output above)" >&2; return 1; }
    echo "   build $dir: done ($(( $(date +%s) - bg_start )) s since it started beside the tests)"
    return 0
  fi
  wait "$bg_pid" || rc=$?
  bg_stage=""
  if [ $rc -ne 0 ]; then cat "$dir.bg.log"; echo "build: $dir failed (log above)" >&2; return 1; fi
  echo "   build $dir: done beside the tests ($(( $(date +%s) - bg_start )) s since it started)"
}
trap '[ -n "$bg_stage" ] && kill -- -"$bg_pid" 2>/dev/null; true' EXIT

# The peers' own programs (LinuxCNC loading our tables: label `peer`) gain nothing from our sanitizers,
# and the CLI steps they run are sanitized in compensate_cli_test: they run in the Release stage only.
label_args=(-LE slow)
asan_label_args=(-LE 'slow|peer')
if [ "${GUIDEWAY_TEST_LABEL:-}" = "slow" ]; then label_args=(); asan_label_args=(-LE peer); fi

read -r -a stage_list <<<"$stages"
for i in "${!stage_list[@]}"; do
  stage=${stage_list[$i]}
  next=${stage_list[$((i + 1))]:-}
  t0=$(date +%s)
  case $stage in
    main) echo "== main build (Release): all tests${label_args:+ but 'slow'}" ;;
    slow) echo "== main build (Release): the tests labelled 'slow'" ;;
    asan) echo "== ASan+UBSan build: all tests but ${asan_label_args[1]//|/ and }" ;;
    tsan) echo "== TSan build: tests labelled 'tsan'" ;;
    *) echo "unknown stage $stage" >&2; exit 2 ;;
  esac
  if [ "$bg_stage" = "$stage" ]; then
    finish_background_build "$stage"
  else
    build_stage "$stage"
  fi
  t_built=$(date +%s)
  if [ -n "$next" ]; then start_background_build "$next"; fi
  case $stage in
    main) run_ctest build "${label_args[@]}" ;;
    slow) run_ctest build -L slow ;;
    asan) ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
            run_ctest build-asan "${asan_label_args[@]}" ;;
    tsan) TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 run_ctest build-tsan -L tsan ;;
  esac
  echo "== $stage stage took $(( $(date +%s) - t0 )) s (build $((t_built - t0)) s, tests $(( $(date +%s) - t_built )) s)"
done
echo "== all stages took $(( $(date +%s) - start )) s"
echo "Total: $passed passed, $failed failed, $skipped not run; $cases_run cases ran, $cases_skipped skipped (reasons above)"
[ "$failed" -eq 0 ]
