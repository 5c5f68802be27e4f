#!/usr/bin/env bash
# The README's real-photo recipe on a real drone flight: the 18 Brighton Beach
# photos (DJI Phantom 3, FC300S, 4000x2250, EXIF GPS and DJI XMP; they live in
# ../shared/data/brighton-beach and are never committed) through COLMAP's SfM
# on the CPU, then vpctl from `colmap align --exif` to a .plan and a .kmz.
#
#   bash scripts/brighton.sh OUT [SIZE]
#
# SIZE (default 2000, half of the photos' 4000 px) is the longest image side,
# in pixels, that COLMAP extracts features at (--SiftExtraction.max_image_size)
# and that `vpctl colmap undistort --max-image-size` writes the dense
# workspace at: dense stereo, prediction and planning all run at that size.
# 4000 is full size; crates/cli/tests/brighton.rs runs 800.
#
# Environment: VPCTL (the binary, default `vpctl` on PATH), PHOTOS (default
# ../shared/data/brighton-beach/images from the project root), FOREST (a
# .vpforest to reuse; default: train the simulator forest the demo trains,
# `vpctl sim train` on `vpctl sim config --preset ${FOREST_PRESET:-demo}`),
# MAX_FEATURES (SIFT features per photo, COLMAP's default 8192; exhaustive
# matching time grows with its square), MVS_CONFIG (a `vpctl mvs run --config` TOML), PLAN_CONFIG (a `vpctl plan
# --config` TOML; default below: the FC300S camera, 5 m safety distance).
#
# Every step prints its wall time, peak memory (GNU time) and output size.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
if [ $# -lt 1 ]; then
  echo "usage: bash scripts/brighton.sh OUT [SIZE]" >&2
  exit 2
fi
out="$1"
size="${2:-2000}"
case "$size" in '' | *[!0-9]*) echo "SIZE must be a number of pixels, got '$size'" >&2; exit 2 ;; esac
vpctl="${VPCTL:-vpctl}"
photos="${PHOTOS:-$root/../shared/data/brighton-beach/images}"
if [ ! -d "$photos" ]; then
  echo "no photos at $photos (set PHOTOS, or put shared/ beside the project)" >&2
  exit 2
fi
for tool in colmap /usr/bin/time; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "$tool not found: apt-get install -y colmap time" >&2
    exit 2
  fi
done
if [ -e "$out" ] && [ -n "$(ls -A "$out")" ]; then
  echo "$out exists and is not empty: give a new folder" >&2
  exit 2
fi
mkdir -p "$out"
out="$(cd "$out" && pwd)"
log="$out/steps.tsv"
printf 'step\twall_s\tpeak_mib\toutput\tsize\n' >"$log"
export QT_QPA_PLATFORM=offscreen

# step NAME OUTPUT CMD...: runs CMD under GNU time, its output in
# $out/logs/NAME.log; prints and records wall time, peak RSS and OUTPUT's size.
mkdir -p "$out/logs"
step() {
  local name="$1" output="$2"
  shift 2
  if ! /usr/bin/time -v -o "$out/logs/$name.time" "$@" >"$out/logs/$name.log" 2>&1; then
    echo "step $name failed: see $out/logs/$name.log" >&2
    tail -n 20 "$out/logs/$name.log" >&2
    exit 1
  fi
  local wall peak bytes
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$out/logs/$name.time")
  peak=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$out/logs/$name.time")
  bytes=$(du -sh "$output" 2>/dev/null | cut -f1)
  printf '%-22s %8.1f s %7s MiB  %s %s\n' "$name" "$wall" "$peak" "$(basename "$output")" "$bytes"
  printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$wall" "$peak" "$(basename "$output")" "$bytes" >>"$log"
}

# 1. COLMAP SfM on the CPU: one OPENCV camera for all photos (one drone, one
# lens), features at SIZE px, every pair matched (18 photos), the mapper.
step features "$out/database.db" colmap feature_extractor \
  --database_path "$out/database.db" --image_path "$photos" \
  --ImageReader.single_camera 1 --ImageReader.camera_model OPENCV \
  --SiftExtraction.use_gpu 0 --SiftExtraction.max_image_size "$size" \
  --SiftExtraction.max_num_features "${MAX_FEATURES:-8192}"
step matching "$out/database.db" colmap exhaustive_matcher \
  --database_path "$out/database.db" --SiftMatching.use_gpu 0
mkdir -p "$out/sparse"
step mapper "$out/sparse" colmap mapper \
  --database_path "$out/database.db" --image_path "$photos" --output_path "$out/sparse"

# 2. vpctl: georegister with the photos' EXIF GPS (altitudes above mean sea
# level, the take-off altitude from DJI's XMP), undistort at SIZE px.
step align "$out/aligned" "$vpctl" colmap align --colmap "$out/sparse/0" --exif "$photos" --out "$out/aligned"
step undistort "$out/dense/images" "$vpctl" colmap undistort --colmap "$out/aligned" --images "$photos" \
  --out "$out/dense" --max-image-size "$size"
mvs_config=()
if [ -n "${MVS_CONFIG:-}" ]; then mvs_config=(--config "$MVS_CONFIG"); fi
step mvs "$out/dense/stereo" "$vpctl" mvs run --workspace "$out/dense" "${mvs_config[@]}"
step mesh "$out/site.ply" "$vpctl" mesh build --points "$out/dense/fused.ply" --method height-field --out "$out/site.ply"

# 3. Confidence: the simulator-trained forest (what `vpctl demo` trains).
forest="${FOREST:-}"
if [ -z "$forest" ]; then
  "$vpctl" sim config --preset "${FOREST_PRESET:-demo}" >"$out/sim.toml"
  forest="$out/forest.vpforest"
  step train "$forest" "$vpctl" sim train --config "$out/sim.toml" --out "$forest"
fi
step predict "$out/conf" "$vpctl" predict --forest "$forest" --out "$out/conf" --no-previews "$out/dense/images"

# 4. The plan: the FC300S at full size (the drone's own camera), a GSD and
# accuracy the 40 m grid nearly gives, 5 m from the reconstructed surface;
# the take-off point on the mesh below the first photo.
plan_config="${PLAN_CONFIG:-$out/plan.toml}"
if [ -z "${PLAN_CONFIG:-}" ]; then
  cat >"$plan_config" <<'EOF'
gsd_m = 0.01
accuracy_m = 0.02
safety_distance_m = 5.0
[camera]
width = 4000
height = 2250
focal_px = 2985.0
EOF
fi
step plan "$out/plan.json" "$vpctl" plan --mesh "$out/site.ply" --colmap "$out/dense/sparse" \
  --confidence-dir "$out/conf" --config "$plan_config" --home-from-first-image \
  --out "$out/plan.json" --glb "$out/plan.glb"
step export-plan "$out/mission.plan" "$vpctl" mission export "$out/plan.json" --out "$out/mission.plan"
step export-kmz "$out/mission.kmz" "$vpctl" mission export "$out/plan.json" --out "$out/mission.kmz" --drone m3e

total=$(awk -F'\t' 'NR > 1 {s += $2} END {printf "%.1f", s}' "$log")
echo "total: $total s at $size px; steps in $log"
