#!/usr/bin/env bash
# Installs what Relief needs on Debian 12: apt-get only what is missing (idempotent).
# Usage: scripts/setup.sh [--with-clients]   (clients: Blender, assimp, Tiled, Chromium — later issues)
set -euo pipefail
packages=(
  g++ cmake ninja-build pkg-config git
  libhwy-dev libtbb-dev nlohmann-json3-dev libcli11-dev libspng-dev
  libgtest-dev libgmock-dev libbenchmark-dev libnoise-dev
  libfreetype-dev fonts-dejavu-core
  python3-pil python3-numpy
  tiled  # tmxrasterizer and `tiled --export-tileset`: the tilemap tests load our TMX/TMJ/TSX in Tiled
)
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
