#!/usr/bin/env bash
# Builds device-kit/: what `run.sh` needs to run shvis's cost table on a bare x86-64 Linux
# machine with any Vulkan GPU — the release binary with its debug sections stripped, the
# Vulkan loader's Debian package (and the C++ runtime's, unpacked only where missing), and
# run.sh. Everything is made here; the kit carries no source and needs no network there.
set -euo pipefail
cd "$(dirname "$0")/../.."
kit=device-kit
cargo build --release --locked
rm -rf "$kit"
mkdir -p "$kit/debs"
cp target/release/shvis "$kit/shvis"
strip --strip-debug "$kit/shvis"
cp scripts/device-kit/run.sh "$kit/run.sh"
chmod +x "$kit/run.sh" "$kit/shvis"
# The packages for amd64 whatever this machine is, from a private package list.
lists=$(mktemp -d)
mkdir -p "$lists/partial"
apt_opts=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 "-oDir::State::Lists=$lists")
if ! (apt-get "${apt_opts[@]}" update -qq &&
  cd "$kit/debs" && apt-get "${apt_opts[@]}" download -qq libvulkan1 libstdc++6 libgcc-s1); then
  echo "error: could not download the Vulkan loader's package (apt-get download libvulkan1)" >&2
  exit 1
fi
rm -rf "$lists"
size=$(du -sm "$kit" | cut -f1)
echo "device kit: $kit/ ($size MiB): $(ls "$kit" "$kit/debs" | tr '\n' ' ')"
if [ "$size" -ge 64 ]; then
  echo "error: the kit is $size MiB; the device machine takes at most 64 MiB" >&2
  exit 1
fi
