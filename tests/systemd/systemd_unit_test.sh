#!/usr/bin/env bash
# Verifies the systemd units (systemd-analyze verify, with ExecStart pointed at the built programs) and
# measures their exposure scores (systemd-analyze security --offline=yes), which must stay below 2.0:
# guidewayd.service and the fleet process's guideway-fleet.service (docs/plant.md).
# Usage: systemd_unit_test.sh SYSTEMD_DIR BUILD_DIR   (writes BUILD_DIR/systemd-security*.txt)
set -euo pipefail
unit_dir=$1
build=$2
if ! command -v systemd-analyze >/dev/null; then
  echo "SKIP: systemd-analyze not installed"; exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

check_unit() {  # unit file name, installed program, built program, security report file
  local unit=$1 installed=$2 built=$3 report=$4 out score
  sed "s|^ExecStart=$installed|ExecStart=$built|" "$unit_dir/$unit" >"$work/$unit"
  out=$(systemd-analyze verify "$work/$unit" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify $unit"; exit 1; }
  # verify exits 0 on some warnings; treat any output about our unit as a failure.
  if grep -q "$unit" <<<"$out"; then echo "$out"; echo "FAIL: systemd-analyze verify warned about $unit"; exit 1; fi
  systemd-analyze security --offline=yes --no-pager "$work/$unit" >"$report" 2>&1 || true
  score=$(grep -oE "Overall exposure level for $unit: [0-9.]+" "$report" | grep -oE '[0-9.]+$')
  echo "$unit exposure: $score"
  awk -v s="$score" 'BEGIN { exit !(s < 2.0) }' || { echo "FAIL: $unit exposure $score is not below 2.0"; exit 1; }
  echo "PASS: $unit verifies, exposure $score"
}
check_unit guidewayd.service /usr/sbin/guidewayd "$build/daemon/guidewayd" "$build/systemd-security.txt"
check_unit guideway-fleet.service /usr/bin/guideway "$build/cli/guideway" "$build/systemd-security-fleet.txt"
