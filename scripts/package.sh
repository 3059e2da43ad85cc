#!/usr/bin/env bash
# Builds Guideway's Debian package and checks it with lintian (docs/linuxcnc.md, "Installing").
# usage: scripts/package.sh [BUILD_DIR]   (default build-package; its own tree: Release, prefix /usr, no tests)
# Prints the package's path last; `sudo apt install ./guideway_*.deb` installs it beside linuxcnc-uspace.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
dir=${1:-build-package}
echo "== building $dir (Release, prefix /usr)"
scripts/build.sh "$dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr -DGUIDEWAY_BUILD_TESTS=OFF \
  -DGUIDEWAY_BUILD_BENCH=OFF
echo "== cpack -G DEB"
rm -f "$dir"/guideway_*.deb
(cd "$dir" && cpack -G DEB >cpack.log 2>&1) || { cat "$dir/cpack.log"; exit 1; }
deb=$(ls "$dir"/guideway_*.deb)
echo "== lintian $(basename "$deb")"
# --fail-on warning: an error or a warning fails the build; the tags lintian names and why are printed.
lintian --fail-on error,warning --tag-display-limit 0 "$deb"
echo "$deb"
