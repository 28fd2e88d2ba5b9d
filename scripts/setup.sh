#!/usr/bin/env bash
# Installs what Relief needs on Debian 12: apt-get only what is missing (idempotent), then the
# studio's npm packages from web/package-lock.json with `npm ci` (skipped when already in place).
# Usage: scripts/setup.sh [--with-clients]   (clients: Blender, assimp, Tiled — later issues)
set -euo pipefail
cd "$(dirname "$0")/.."
packages=(
  g++ cmake ninja-build pkg-config git
  libhwy-dev libtbb-dev nlohmann-json3-dev libcli11-dev libspng-dev
  libgtest-dev libgmock-dev libbenchmark-dev libnoise-dev
  python3-pil python3-numpy
  # relief studio: HTTP server, zip archives for exports, the browser its tests drive
  libcpp-httplib-dev libarchive-dev chromium
)
# Node.js and npm build the studio's front end: Debian's when the machine has none.
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
# The studio's npm packages (three, lil-gui, esbuild; playwright-core and gltf-validator for the
# tests), exactly as locked. Re-run only when the lock file changed since the last install.
if [ ! -f web/node_modules/.package-lock.json ] || [ web/package-lock.json -nt web/node_modules/.package-lock.json ]; then
  echo "setup: npm ci in web/"
  (cd web && npm ci --no-audit --no-fund --loglevel=error)
else
  echo "setup: web/node_modules up to date"
fi
