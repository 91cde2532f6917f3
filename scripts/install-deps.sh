#!/usr/bin/env bash
# Installs what shvis needs on Debian when it is missing: the Vulkan loader, Mesa's
# lavapipe (CPU Vulkan), the Khronos validation layer, and shaderc + glslang static
# libraries (linked by build.rs), the DejaVu font for plot labels, Chromium (the headless
# browser test of the bench's index.html) and Xvfb (the `shvis view` test's display),
# Node.js and npm; then the engine-side tests' npm packages, pinned by
# tests/engine/package-lock.json (`npm ci`). As root it runs apt-get; otherwise it prints
# the exact command and fails.
set -euo pipefail

packages=(libvulkan1 mesa-vulkan-drivers vulkan-validationlayers libshaderc-dev glslang-dev fonts-dejavu-core chromium xvfb xauth)
# Node.js from elsewhere (nvm, a tarball) serves as well as Debian's.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo is not on PATH; install Rust (https://rustup.rs) first" >&2
  exit 1
fi

# The engine-side tests' npm packages, as the lockfile pins them.
npm_packages() {
  local dir=tests/engine
  if [ ! -f "$dir/node_modules/.package-lock.json" ] || [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    echo "installing the engine tests' npm packages (npm ci in $dir)"
    npm ci --prefix "$dir" --no-audit --no-fund --loglevel=error
  fi
}

if [ ${#missing[@]} -eq 0 ]; then
  npm_packages
  exit 0
fi

if ! command -v apt-get >/dev/null 2>&1; then
  echo "error: missing packages (${missing[*]}) and no apt-get: install the Vulkan loader, Mesa lavapipe, the Khronos validation layer, shaderc/glslang static libraries and Chromium by hand" >&2
  exit 1
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "error: missing Debian packages: ${missing[*]}" >&2
  echo "run: sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
  exit 1
fi

echo "installing: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "installed: ${missing[*]}"
npm_packages
