#!/usr/bin/env bash
# Regenerates docs/img/report_*.png (docs/reports.md): builds guideway and guideway-emulate in BUILD_DIR
# (default build/), renders the example inputs into one report and screenshots each plot type in headless
# Chromium. Usage: report/tools/docs_screenshots.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=${1:-build}
./scripts/setup.sh
./scripts/build.sh "$dir" -- guideway guideway-emulate
/usr/bin/python3 report/tools/screenshots.py "$dir/cli/guideway" "$dir/simulators/emulators/guideway-emulate" docs/img
