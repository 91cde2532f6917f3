#!/usr/bin/env bash
# shvis device kit: the paper's cost table on this machine's Vulkan GPU.
#
#   run.sh OUT [--small]
#
# Lists the Vulkan devices (shvis picks the first discrete GPU), then runs the bench — the
# device probe and every technique on dx9 and dx10 — at 1280×800 (with the error columns)
# and at 3840×2160 (times only), into OUT/<device>/<width>x<height>/, and packs the text
# results into OUT/results.tar.gz. Each step's time is printed as it ends, so a run cut off
# still says where it was. --small: small settings for a check on a CPU device (lavapipe).
# Needs no network: the Vulkan loader comes from the kit's debs/ when the machine has none.
set -uo pipefail
kit=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: run.sh OUT [--small]}
small=0
[ "${2:-}" = "--small" ] && small=1
mkdir -p "$out"
out=$(cd "$out" && pwd)
exec > >(tee -a "$out/run.log") 2>&1
started=$(date +%s)

# Runs "$@" as step $1, printing its time and the time so far.
step() {
  local name=$1 begun rc
  shift
  begun=$(date +%s)
  echo "== $name: $*"
  "$@"
  rc=$?
  echo "== $name: $(($(date +%s) - begun)) s, exit $rc ($(($(date +%s) - started)) s in all)"
  return $rc
}

# Unpacks the kit's packages named by $@ into the kit's own root and adds its libraries to
# the search path (as root the Vulkan loader goes to /, where the ICDs expect it).
unpack() {
  for p in "$@"; do
    for f in "$kit"/debs/"${p}"_*.deb; do
      if [ "$p" = libvulkan1 ] && [ "$(id -u)" = 0 ]; then
        dpkg -x "$f" /
      else
        dpkg -x "$f" "$kit/root"
      fi
    done
  done
  [ "$(id -u)" = 0 ] && ldconfig
  export LD_LIBRARY_PATH="$kit/root/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
}

if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1'; then
  echo "no Vulkan loader installed: using the kit's"
  unpack libvulkan1
fi
if ldd "$kit/shvis" 2>/dev/null | grep -q 'not found'; then
  echo "missing C++ runtime libraries: using the kit's"
  unpack libstdc++6 libgcc-s1
fi

shvis=$kit/shvis
export SHVIS_CACHE_DIR="$kit/cache" RUST_LOG="${RUST_LOG:-shvis=info,warn}"
if ! step devices "$shvis" devices; then
  # No driver found by the loader: the NVIDIA ICD where NVIDIA's container puts it.
  for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json \
    /usr/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json; do
    if [ -f "$icd" ]; then
      export VK_DRIVER_FILES=$icd
      echo "VK_DRIVER_FILES=$icd"
      break
    fi
  done
  step devices "$shvis" devices || { echo "error: no Vulkan device"; exit 1; }
fi
"$shvis" devices --json >"$out/devices.json" 2>/dev/null
name=$("$shvis" devices 2>/dev/null | sed -n 's/^\* \(.*\) (\(discrete GPU\|integrated GPU\|virtual GPU\|CPU\|other\)) ·.*/\1/p' | head -n 1)
device=$(printf '%s' "${name:-device}" | tr -c 'A-Za-z0-9._-' '_' | sed 's/__*/_/g; s/_$//')
echo "device: $name → $out/$device"

if [ "$small" = 1 ]; then
  sizes=("320 200 16" "640 360 0")
  quality=(--vis-res 128 --rays 256 --frames 3 --warmup 1)
else
  sizes=("1280 800 16" "3840 2160 0")
  quality=()
fi
failed=0
for size in "${sizes[@]}"; do
  read -r w h spp <<<"$size"
  dir="$out/$device/${w}x$h"
  mkdir -p "$dir"
  extra=()
  # Times only at the large size: no reference, no probe (the model is the small size's).
  [ "$spp" = 0 ] && extra=(--no-probe)
  step "bench ${w}x$h" "$shvis" bench --width "$w" --height "$h" --ref-spp "$spp" \
    "${quality[@]}" "${extra[@]}" --out "$dir" || failed=1
done

# The text results in one archive (the device machine returns few files).
(cd "$out" && tar czf results.tar.gz run.log devices.json \
  $(find "$device" -maxdepth 2 \( -name 'table.*' -o -name 'probe.*' -o -name 'index.html' -o -name '*.svg' \) | sort))
echo "== done: $(($(date +%s) - started)) s; $out/results.tar.gz ($(du -h "$out/results.tar.gz" | cut -f1))"
exit $failed
