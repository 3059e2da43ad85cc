#!/usr/bin/env bash
# Verifies the systemd unit (systemd-analyze verify, with ExecStart pointed at the built daemon) and
# measures its exposure score (systemd-analyze security --offline=yes), which must stay below 2.0.
# Usage: systemd_unit_test.sh SYSTEMD_DIR BUILD_DIR   (writes BUILD_DIR/systemd-security.txt)
set -euo pipefail
unit_dir=$1
build=$2
if ! command -v systemd-analyze >/dev/null; then
  echo "SKIP: systemd-analyze not installed"; exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sed "s|^ExecStart=/usr/sbin/guidewayd|ExecStart=$build/daemon/guidewayd|" "$unit_dir/guidewayd.service" >"$work/guidewayd.service"
out=$(systemd-analyze verify "$work/guidewayd.service" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify"; exit 1; }
# verify exits 0 on some warnings; treat any output about our unit as a failure.
if grep -q "guidewayd.service" <<<"$out"; then echo "$out"; echo "FAIL: systemd-analyze verify warned"; exit 1; fi
systemd-analyze security --offline=yes --no-pager "$work/guidewayd.service" >"$build/systemd-security.txt" 2>&1 || true
score=$(grep -oE 'Overall exposure level for guidewayd.service: [0-9.]+' "$build/systemd-security.txt" | grep -oE '[0-9.]+$')
echo "exposure: $score"
awk -v s="$score" 'BEGIN { exit !(s < 2.0) }' || { echo "FAIL: exposure $score is not below 2.0"; exit 1; }
echo "PASS: unit verifies, exposure $score"

# The fleet process's unit (docs/plant.md): the same checks, ExecStart pointed at the built CLI.
sed "s|^ExecStart=/usr/bin/guideway|ExecStart=$build/cli/guideway|" "$unit_dir/guideway-fleet.service" >"$work/guideway-fleet.service"
out=$(systemd-analyze verify "$work/guideway-fleet.service" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify (fleet)"; exit 1; }
if grep -q "guideway-fleet.service" <<<"$out"; then echo "$out"; echo "FAIL: systemd-analyze verify warned (fleet)"; exit 1; fi
systemd-analyze security --offline=yes --no-pager "$work/guideway-fleet.service" >"$build/systemd-security-fleet.txt" 2>&1 || true
score=$(grep -oE 'Overall exposure level for guideway-fleet.service: [0-9.]+' "$build/systemd-security-fleet.txt" | grep -oE '[0-9.]+$')
echo "fleet exposure: $score"
awk -v s="$score" 'BEGIN { exit !(s < 2.0) }' || { echo "FAIL: fleet exposure $score is not below 2.0"; exit 1; }
echo "PASS: fleet unit verifies, exposure $score"
