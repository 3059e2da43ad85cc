#!/usr/bin/env bash
# The main job: builds Guideway, starts guidewayd on its embedded default (emulated instruments, no
# hardware, socket in a per-user location), and shows it working through the `guideway` client.
# --keep leaves the daemon running afterwards (stop it with: kill $(cat "$state/guidewayd.pid")).
# --machine FILE: the virtual machine tool the emulators run (default config/machine-example.toml;
# config/machine-several-effects.toml has several DBB-visible effects at once).
set -euo pipefail
cd "$(dirname "$0")/.."
keep=0
machine=config/machine-example.toml
while [ $# -gt 0 ]; do
  case $1 in
    --keep) keep=1 ;;
    --machine) machine=${2:?--machine needs a file}; shift ;;
    *) echo "usage: $0 [--keep] [--machine FILE]" >&2; exit 2 ;;
  esac
  shift
done
[ -f "$machine" ] || { echo "demo: no such machine file: $machine" >&2; exit 2; }
./scripts/setup.sh
echo "== building (first time: a few minutes)"
scripts/build.sh build -DCMAKE_BUILD_TYPE=Release -- guideway_runtime

bin=build
run_dir=${XDG_RUNTIME_DIR:-/tmp/guideway-$(id -u)}
mkdir -p "$run_dir"
log="$run_dir/guidewayd-demo.log"
echo "== starting guidewayd (log: $log)"
"$bin/daemon/guidewayd" --emulator-machine "$machine" >"$log" 2>&1 &
pid=$!
cleanup() { if [ $keep -eq 0 ] && kill -0 "$pid" 2>/dev/null; then kill -TERM "$pid"; wait "$pid" || true; fi; }
trap cleanup EXIT

for _ in $(seq 1 100); do
  "$bin/cli/guideway" version >/dev/null 2>&1 && break
  if ! kill -0 "$pid" 2>/dev/null; then cat "$log"; echo "guidewayd exited" >&2; exit 1; fi
  sleep 0.1
done
# Another daemon (a previous --keep) can answer while ours refuses its socket and exits: not ours.
sleep 0.3
if ! kill -0 "$pid" 2>/dev/null; then
  cat "$log"; echo "guidewayd exited (is one already running? its pid: $run_dir/guidewayd.pid)" >&2; exit 1
fi
echo "$pid" >"$run_dir/guidewayd.pid"
"$bin/cli/guideway" version
# The daemon's latest EXPLAIN of a kind (it comes a moment after the PARAMS), beside what the machine file holds.
explain_latest() {
  for _ in $(seq 1 100); do
    "$bin/cli/guideway" explain --latest --kind "$1" >/dev/null 2>&1 && break
    sleep 0.3
  done
  "$bin/cli/guideway" explain --latest --kind "$1" --machine "$machine" || true
}
# The emulated instruments connect within a second or two.
for _ in $(seq 1 50); do
  "$bin/cli/guideway" status --json | grep -q '"state":"connecting"' || break
  sleep 0.2
done
echo
echo "== guideway status"
"$bin/cli/guideway" status
echo
echo "== guideway start dbb --wait   (the standard ballbar test on the emulated machine: ccw and cw circles at"
echo "   h = 0 in XY, r = 100 mm, 1000 mm/min; 100-150 s, by where in its program the machine is)"
"$bin/cli/guideway" start dbb --wait --timeout 400
echo
echo "== guideway explain --latest --machine $machine"
echo "   (what the model left out, fitted and checked on held-out data, beside what the machine file holds)"
explain_latest dbb
echo
echo "== guideway start runout --set revolutions=8 --wait   (the spindle's run-out on the emulated micrometer: a probe"
echo "   on the spindle at 500 mm over the thrust plate, 8 revolutions at 60 rpm, 8 s; Mu's Eq. 21 squareness and"
echo "   the ISO 230-7 error motions, the once-per-revolution term removed)"
"$bin/cli/guideway" start runout --set revolutions=8 --wait --timeout 120
echo
echo "== guideway explain --latest --kind runout --machine $machine"
echo "   (the spindle's error motions named from the run-out record, beside what the machine file's [spindle] holds)"
explain_latest runout
echo
echo "== guideway compensate dbb --latest --verify   (LinuxCNC tables and the axis skew from the session's"
echo "   ballbar diagnostics, with what EXPLAIN found fitted beside, then the two circles traced again on"
echo "   $machine with them loaded; a file that makes a run's G larger is refused: DO NOT LOAD, renamed"
echo "   *.do-not-load; docs/compensation.md)"
comp_dir="$run_dir/compensation-demo"
mkdir -p "$comp_dir"
"$bin/cli/guideway" compensate dbb --latest --out-dir "$comp_dir/session" --verify --machine "$machine"
"$bin/cli/guideway" report "$comp_dir"/session/verify/*.csv --out "$comp_dir/session-before-after.html"
echo "== before/after polar plots of the session's circles: open $comp_dir/session-before-after.html in a browser"
echo
echo "== guideway recordings"
"$bin/cli/guideway" recordings
report_file=$(ls -t "${XDG_STATE_HOME:-$HOME/.local/state}"/guideway/dbb-*.report.html 2>/dev/null | head -1 || true)
if [ -n "$report_file" ]; then
  echo
  echo "== the session's report (plots): open $report_file in a browser"
fi
if [ $keep -eq 1 ]; then
  echo
  echo "guidewayd keeps running (pid $pid). Try: $bin/cli/guideway watch --class SAMPLE --channel dbb    Stop: kill $pid"
fi
