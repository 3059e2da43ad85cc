#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, then
#   1. a Release build (as packagers build): every test, the long ones (label `slow`) too, so that a slow
#      failure cannot land unseen (issue 46), but those labelled `checkout` (they run ./scripts/demo.sh in
#      the checkout itself: its build/ and the user's default socket);
#   2. an ASan+UBSan build: every test except `slow` and `peer` (a peer's program run against our files);
#   3. a TSan build of the threaded code: the tests labelled `tsan` (ring stress, daemon threads).
# GUIDEWAY_TEST_STAGES="main asan tsan" selects stages; GUIDEWAY_TEST_LABEL=slow adds the `checkout` tests
# to the Release stage and the long variants to the ASan stage.
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
  local out junit
  junit="$(cd "$dir" && pwd)/Testing/junit.xml"
  rm -f "$junit"
  set +e
  out=$(ctest --test-dir "$dir" --output-on-failure -j "$jobs" --output-junit "$junit" \
    --test-output-size-passed 50000000 "$@" 2>&1)
  local rc=$?
  set -e
  echo "$out" | grep -vE '^\s*(Start|Test project)' || true
  if [ -f "$junit" ]; then
    local summary counts
    summary=$(python3 scripts/test_summary.py "$stage" "$junit")
    echo "$summary" | grep -v '^COUNTS '
    counts=($(echo "$summary" | grep '^COUNTS ' | cut -d' ' -f2-))
    passed=$((passed + counts[0])); failed=$((failed + counts[1])); skipped=$((skipped + counts[2]))
    cases_run=$((cases_run + counts[3])); cases_skipped=$((cases_skipped + counts[4]))
  elif [ $rc -ne 0 ]; then
    failed=$((failed + 1))
  fi
  return 0
}

label_args=(-LE checkout)
# The peers' own programs (LinuxCNC loading our tables: label `peer`) gain nothing from our sanitizers,
# and the CLI steps they run are sanitized in compensate_cli_test: they run in the Release stage only.
asan_label_args=(-LE 'slow|peer')
if [ "${GUIDEWAY_TEST_LABEL:-}" = "slow" ]; then label_args=(); asan_label_args=(-LE peer); fi

for stage in $stages; do
  t0=$(date +%s)
  case $stage in
    main)
      echo "== main build (Release): all tests, 'slow' too, but 'checkout'"
      scripts/build.sh build -DCMAKE_BUILD_TYPE=Release -DGUIDEWAY_BUILD_TESTS=ON -DGUIDEWAY_BUILD_BENCH=ON
      run_ctest build "${label_args[@]}" ;;
    asan)
      echo "== ASan+UBSan build: all tests but 'slow' and 'peer'"
      # -g1 (line tables), as CMakeLists.txt's RelWithDebInfo default: sanitizer reports need only file:line.
      # Test programs and the CLI at -O0 (GUIDEWAY_THIN_PROGRAM_FLAGS): half their compile time, and the
      # libraries under test keep -O1.
      scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=Debug -DGUIDEWAY_SANITIZE=address -DGUIDEWAY_BUILD_BENCH=OFF \
        -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DGUIDEWAY_THIN_PROGRAM_FLAGS=-O0
      ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        run_ctest build-asan "${asan_label_args[@]}" ;;
    tsan)
      echo "== TSan build: tests labelled 'tsan'"
      scripts/build.sh build-tsan -DCMAKE_BUILD_TYPE=Debug -DGUIDEWAY_SANITIZE=thread -DGUIDEWAY_BUILD_BENCH=OFF \
        -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DGUIDEWAY_THIN_PROGRAM_FLAGS=-O0 -- guideway_tsan_tests
      TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1 run_ctest build-tsan -L tsan ;;
    *) echo "unknown stage $stage" >&2; exit 2 ;;
  esac
  echo "== $stage stage took $(( $(date +%s) - t0 )) s"
done
echo "== all stages took $(( $(date +%s) - start )) s"
echo "Total: $passed passed, $failed failed, $skipped not run; $cases_run cases ran, $cases_skipped skipped (reasons above)"
[ "$failed" -eq 0 ]
