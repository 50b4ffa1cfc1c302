#!/usr/bin/env bash
# The renderer's table (issue 42) on this machine's GPU beside lavapipe: frames/s of the chessboard,
# ChArUco, S-path, fisheye, mesh and effects scenes at 1280 x 1024 and 3840 x 3072, dataset images/s
# and the IBVS loop's steps/s, each headed by the adapter's name; then whether the GPU's images equal
# lavapipe's (the largest difference in grey levels and the pixels that differ, per scene).
#
#   benches/gpu.sh [OUT]      (default out/gpu-report: OUT/lavapipe and OUT/default, each with the
#                              scenes' PNGs and report.json)
#
# Needs cargo, Mesa's lavapipe (mesa-vulkan-drivers) and the GPU's Vulkan driver. On a machine with no
# GPU both runs are lavapipe and every image is identical.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-out/gpu-report}"
export NODEVICE_SELECT=1
cargo build --release --quiet
BIN=target/release/synthcam
LVP="$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json 2>/dev/null | head -1 || true)"
if [ -n "$LVP" ]; then
  echo "== lavapipe, the reference ($LVP)"
  VK_DRIVER_FILES="$LVP" VK_ICD_FILENAMES="$LVP" "$BIN" bench --report --backend vulkan --out "$OUT/lavapipe"
  echo
  echo "== the default adapter, its images against lavapipe's"
  "$BIN" bench --report --out "$OUT/default" --compare "$OUT/lavapipe"
else
  echo "no lavapipe ICD under /usr/share/vulkan/icd.d: the default adapter alone"
  "$BIN" bench --report --out "$OUT/default"
fi
