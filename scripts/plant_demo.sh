#!/usr/bin/env bash
# Plant scale on this one machine (docs/plant.md): an MQTT broker (Debian's mosquitto, loopback), two
# guidewayd on emulated machine tools with different errors publishing to it, the fleet process
# storing what they publish, a DBB test on each machine (and a second one on mill-1), then the fleet
# view: `guideway fleet status`, `history`, `report`.
# --keep leaves the broker, the daemons and the fleet running (their pids in DIR/*.pid).
# GUIDEWAY_PLANT_PORT: the broker's port (default 18830); GUIDEWAY_PLANT_DIR: where everything goes.
set -euo pipefail
cd "$(dirname "$0")/.."
keep=0
[ "${1:-}" = "--keep" ] && keep=1
./scripts/setup.sh
echo "== building (first time: a few minutes)"
scripts/build.sh build -DCMAKE_BUILD_TYPE=Release -- guideway_runtime
bin=$PWD/build
port=${GUIDEWAY_PLANT_PORT:-18830}
dir=${GUIDEWAY_PLANT_DIR:-${XDG_RUNTIME_DIR:-/tmp/guideway-$(id -u)}/plant-demo}
rm -rf "$dir"
mkdir -p "$dir"
chmod 0700 "$dir"
pids=()
# Stopped in the reverse order of starting: the daemons and the fleet first (each says "offline",
# "stopped" while the broker is there to take it), the broker last, so no one logs "connection lost".
cleanup() {
  if [ $keep -eq 0 ]; then
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
      kill -TERM "${pids[i]}" 2>/dev/null || true
      wait "${pids[i]}" 2>/dev/null || true
    done
  fi
}
trap cleanup EXIT
wait_until() {  # seconds, command...
  local n=$(( $1 * 10 )); shift
  for _ in $(seq 1 "$n"); do "$@" >/dev/null 2>&1 && return 0; sleep 0.1; done
  return 1
}

echo "== the broker: mosquitto on 127.0.0.1:$port (log $dir/mosquitto.log)"
mosquitto=$(command -v mosquitto || echo /usr/sbin/mosquitto)
cat >"$dir/mosquitto.conf" <<CONF
user $(id -un)
listener $port 127.0.0.1
allow_anonymous true
persistence true
persistence_location $dir/
CONF
"$mosquitto" -c "$dir/mosquitto.conf" >"$dir/mosquitto.log" 2>&1 &
pids+=($!); echo $! >"$dir/mosquitto.pid"
wait_until 10 bash -c "exec 3<>/dev/tcp/127.0.0.1/$port" || { cat "$dir/mosquitto.log"; echo "mosquitto did not start (port $port taken? set GUIDEWAY_PLANT_PORT)" >&2; exit 1; }

echo "== the fleet process: guideway fleet serve (database $dir/fleet.sqlite, log $dir/fleet.log)"
"$bin/cli/guideway" fleet serve --broker "mqtt://127.0.0.1:$port" --db "$dir/fleet.sqlite" >"$dir/fleet.log" 2>&1 &
pids+=($!); echo $! >"$dir/fleet.pid"

# Two machine tools: the example machine, and one with several effects at once (docs/machine.md).
start_daemon() {  # name, machine file
  local name=$1 machine=$PWD/$2
  cat >"$dir/$name.toml" <<CONF
[daemon]
socket = "$dir/$name/guideway.sock"
state_dir = "$dir/$name/state"
emulator_machine = "$machine"

$(cat config/dbb-node.toml)

[mqtt]
broker = "mqtt://127.0.0.1:$port"
machine = "$name"
CONF
  mkdir -p "$dir/$name"
  "$bin/daemon/guidewayd" --config "$dir/$name.toml" >"$dir/$name.log" 2>&1 &
  pids+=($!); echo $! >"$dir/$name.pid"
  wait_until 30 "$bin/cli/guideway" --socket "$dir/$name/guideway.sock" version || { cat "$dir/$name.log"; exit 1; }
  echo "   $name: guidewayd on $2 (socket $dir/$name/guideway.sock, log $dir/$name.log)"
}
echo "== two daemons on emulated machine tools"
start_daemon mill-1 config/machine-example.toml
start_daemon mill-2 config/machine-several-effects.toml
wait_until 10 bash -c "'$bin/cli/guideway' --socket '$dir/mill-1/guideway.sock' status --json | grep -q '\"state\":\"connected\"'"
echo
echo "== a DBB test (the standard test: ccw and cw circles, r 100 mm, at 5000 mm/min; about 20 s) on both machines at once"
# Each machine's progress lines (standard error) under its name; the parameters (standard output) to a file.
start_dbb() {  # name, where its parameters go
  "$bin/cli/guideway" --socket "$dir/$1/guideway.sock" start dbb --set feed_mm_per_min=5000 --wait --timeout 300 \
    2>&1 >"$2" | sed -u "s/^ */   $1: /"
}
start_dbb mill-1 "$dir/mill-1.dbb.txt" &
one=$!
start_dbb mill-2 "$dir/mill-2.dbb.txt"
wait $one
echo "== a second DBB test on mill-1 (its history; a figure is flagged only if it moved beyond its uncertainty)"
# The first test's explanation is still being computed (the device is busy until then).
sessions_done() {  # socket: no session running or finishing
  "$bin/cli/guideway" --socket "$1" status --json | python3 -c \
    'import json, sys; sys.exit(any(s["state"] in ("running", "finishing") for s in json.load(sys.stdin)["sessions"]))'
}
wait_until 120 sessions_done "$dir/mill-1/guideway.sock"
start_dbb mill-1 /dev/null
# The EXPLAIN of the last test follows its PARAMS by a few seconds.
wait_until 60 bash -c "[ \$('$bin/cli/guideway' fleet history mill-1 --db '$dir/fleet.sqlite' --json | grep -o '\"EXPLAIN\"' | wc -l) -ge 2 ]" || true
echo
echo "== guideway fleet status"
"$bin/cli/guideway" fleet status --db "$dir/fleet.sqlite"
echo
echo "== guideway fleet history mill-1"
"$bin/cli/guideway" fleet history mill-1 --db "$dir/fleet.sqlite"
echo
"$bin/cli/guideway" fleet report --db "$dir/fleet.sqlite" --out "$dir/fleet.html"
echo "== the fleet report (trend plots): open $dir/fleet.html in a browser"
echo
echo "== what the broker holds for a newcomer (its retained messages, first 160 characters of each):"
echo "   mosquitto_sub -p $port -t 'guideway/#' -v --retained-only -W 2"
mosquitto_sub -p "$port" -t 'guideway/#' -v --retained-only -W 2 2>/dev/null | cut -c1-160 || true
if [ $keep -eq 1 ]; then
  echo "everything keeps running (the command above works until you stop it); stop it with: kill \$(cat $dir/*.pid)"
else
  echo "(the broker, the daemons and the fleet stop now; ./scripts/plant_demo.sh --keep leaves them running)"
fi
