#!/usr/bin/env bash
# Installs what Relief needs on Debian 12: apt-get only what is missing (idempotent), then the npm
# tools the tests run (tools/package-lock.json, `npm ci`, only when tools/node_modules is stale).
# The client tools the test suite drives (Blender about 600 MB, assimp, node) are part of the set.
set -euo pipefail
packages=(
  g++ cmake ninja-build pkg-config git
  libhwy-dev libtbb-dev nlohmann-json3-dev libcli11-dev libspng-dev
  libgtest-dev libgmock-dev libbenchmark-dev libnoise-dev
  libfreetype-dev fonts-dejavu-core
  python3-pil python3-numpy
  tiled  # tmxrasterizer and `tiled --export-tileset`: the tilemap tests load our TMX/TMJ/TSX in Tiled
  libtinygltf-dev libstb-dev libmeshoptimizer-dev libopenexr-dev zlib1g-dev
  assimp-utils blender
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

# npm tools for the tests (Khronos glTF validator), pinned by tools/package-lock.json.
cd "$(dirname "$0")/../tools"
if [ ! -f node_modules/.package-lock.json ] || ! cmp -s package-lock.json .installed-lock.json; then
  echo "setup: npm ci in tools/"
  npm ci --no-audit --no-fund --loglevel=error
  cp package-lock.json .installed-lock.json
fi
