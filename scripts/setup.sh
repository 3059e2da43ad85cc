#!/usr/bin/env bash
# Installs the Debian packages Guideway needs to build, test and benchmark.
# Idempotent and quiet when nothing is missing. Needs root (or sudo) only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  lld  # links the ~60 test and tool executables about 3x faster than ld.bfd (CMake uses it when present)
  clang libclang-rt-dev  # the sanitizer stages' compiler and its ASan/UBSan/TSan runtimes (scripts/test.sh)
  ccache  # a rebuild (another build tree, another worktree, the next CI stage's unchanged files) reuses objects
  libeigen3-dev libmodbus-dev libserialport-dev libspdlog-dev libfmt-dev zlib1g-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libtomlplusplus-dev nlohmann-json3-dev libcli11-dev libsystemd-dev
  libboost-dev libreaderwriterqueue-dev
  libmosquitto-dev libsqlite3-dev  # plant scale: the MQTT publisher and the fleet's history (docs/plant.md)
  libssl-dev  # the fleet's own MQTT client (TLS): it acknowledges only what it has stored (docs/plant.md)
  mosquitto mosquitto-clients openssl  # the MQTT tests' real broker, their subscriber and their TLS certificates
  python3 python3-numpy python3-scipy python3-pywt
  python3-pymodbus python3-serial-asyncio mbpoll  # Modbus stacks written elsewhere, for the micrometer's tests
  linux-perf  # bench/daemon_load.py --syscalls, bench/controller_load.py (a daemon's threads on the measured CPU)
  rt-tests  # cyclictest: bench/controller_load.py measures a real-time loop beside guidewayd
  linuxcnc-uspace  # the controller Guideway's compensation tables are for: tests/linuxcnc/linuxcnc_comp_test.py runs it headless
  lintian fakeroot dpkg-dev  # the Debian package (scripts/package.sh) built and checked by tests/packaging/package_test.py
  chromium  # headless: the report tests and docs/reports.md screenshots
  systemd
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "setup: installing ${missing[*]}" >&2
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq >/dev/null
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
