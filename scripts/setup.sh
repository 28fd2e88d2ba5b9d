#!/usr/bin/env bash
# Installs what Relief needs on Debian 12: apt-get only what is missing (idempotent), then the
# npm packages from the committed lock files with `npm ci` (tools/: the Khronos glTF validator;
# web/: the studio's front end and its browser tests), each skipped when already in place.
# The client tools the test suite drives (Blender about 600 MB, assimp, Tiled, Chromium) are part
# of the set.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
packages=(
  g++ cmake ninja-build pkg-config git
  libhwy-dev libtbb-dev nlohmann-json3-dev libcli11-dev libspng-dev
  libgtest-dev libgmock-dev libbenchmark-dev libnoise-dev
  libfreetype-dev fonts-dejavu-core
  python3-pil python3-numpy
  # exports: glTF, meshes, EXR, FBX compression, and the real clients that load our files
  libtinygltf-dev libstb-dev libmeshoptimizer-dev libopenexr-dev zlib1g-dev
  assimp-utils blender
  # tilemaps: tmxrasterizer and `tiled --export-tileset` load our TMX/TMJ/TSX
  tiled
  # relief studio: HTTP server, zip archives for exports, the browser its tests drive
  libcpp-httplib-dev libarchive-dev chromium
  # tests: which system calls a run makes (generate --sync flushes each file before its rename)
  strace
  # the Python module and the Blender add-on (pybind11 against Debian's Python 3.11); python3-noise
  # is the peer the compat functions are tested and measured against
  pybind11-dev python3-dev python3-pytest python3-noise
  # inputs: GeoTIFF and the other elevation formats GDAL reads, and GDAL's tools in the tests
  libgdal-dev gdal-bin
  # volumes (caves): OpenVDB for .vdb output and the meshing peer (its headers need Boost, which
  # the package does not pull in); python3-openvdb reads our .vdb files back in the tests
  libopenvdb-dev libboost-dev python3-openvdb
  # worlds: Open MPI for `mpirun -n P relief world`
  libopenmpi-dev openmpi-bin
)
# Node and npm: any install that provides the commands will do (Debian's nodejs + npm by default).
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all packages present"
fi

# npm packages, exactly as locked; re-installed only when the lock file changed since the last install.
for dir in tools web; do
  if [ ! -f "$root/$dir/node_modules/.package-lock.json" ] || ! cmp -s "$root/$dir/package-lock.json" "$root/$dir/node_modules/.relief-installed-lock.json"; then
    echo "setup: npm ci in $dir/"
    (cd "$root/$dir" && npm ci --no-audit --no-fund --loglevel=error && cp package-lock.json node_modules/.relief-installed-lock.json)
  else
    echo "setup: $dir/node_modules up to date"
  fi
done
