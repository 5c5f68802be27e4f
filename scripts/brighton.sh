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
# matching time grows with its square), MIN_REGISTERED (fewest photos
# COLMAP must register, default half of them), MVS_CONFIG (a `vpctl mvs run --config` TOML), PLAN_CONFIG (a `vpctl plan
# --config` TOML; default below: the FC300S camera, 5 m safety distance),
# BRIGHTON_OWN_FOREST=1 (also train Brighton's own forest and score both
# forests on held-out labels: step 5), HELDOUT (step 5's held-out photos).
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
printf 'step\twall_s\tcpu_s\tpeak_mib\toutput\tsize\n' >"$log"
export QT_QPA_PLATFORM=offscreen

# step NAME OUTPUT CMD...: runs CMD under GNU time, its output in
# $out/logs/NAME.log; prints and records wall time, CPU time (user + system,
# all threads: on a shared machine the wall time is the load's, the CPU time
# the step's own), peak RSS and OUTPUT's size.
mkdir -p "$out/logs"
step() {
  local name="$1" output="$2"
  shift 2
  if ! /usr/bin/time -v -o "$out/logs/$name.time" "$@" >"$out/logs/$name.log" 2>&1; then
    echo "step $name failed: see $out/logs/$name.log" >&2
    tail -n 20 "$out/logs/$name.log" >&2
    exit 1
  fi
  local wall cpu peak bytes
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$out/logs/$name.time")
  cpu=$(awk -F': ' '/(User|System) time \(seconds\)/ {s += $2} END {printf "%.1f", s}' "$out/logs/$name.time")
  peak=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$out/logs/$name.time")
  bytes=$(du -sh "$output" 2>/dev/null | cut -f1)
  printf '%-12s %8.1f s wall %8.1f s CPU %7s MiB  %s %s\n' "$name" "$wall" "$cpu" "$peak" "$(basename "$output")" "$bytes"
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$wall" "$cpu" "$peak" "$(basename "$output")" "$bytes" >>"$log"
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

# The mapper may split a flight into several models (sparse/0, sparse/1, ...)
# and need not number the largest 0: the recipe goes on with the model that
# registered the most photos, and stops here when that is fewer than
# MIN_REGISTERED (default: half the photos) -- a plan from a fragment of the
# flight would silently leave the rest of the site out.
n_photos=$(find "$photos" -maxdepth 1 -type f -iname '*.jp*g' | wc -l)
min_registered="${MIN_REGISTERED:-$(((n_photos + 1) / 2))}"
model="" registered=0
for m in "$out"/sparse/*/; do
  [ -d "$m" ] || continue
  n=$("$vpctl" colmap info "$m" 2>/dev/null | awk '/^images:/ {print $2}') || n=0
  if [ "${n:-0}" -gt "$registered" ]; then model="${m%/}" registered="$n"; fi
done
echo "COLMAP registered $registered of $n_photos photos (${model:-no model})"
if [ "$registered" -lt "$min_registered" ]; then
  echo "COLMAP registered $registered of $n_photos photos, fewer than $min_registered" \
    "(MIN_REGISTERED): too little overlap or too few features; try MAX_FEATURES=8192," \
    "a larger SIZE, or check the photos in $out/logs/mapper.log" >&2
  exit 2
fi

# 2. vpctl: georegister with the photos' EXIF GPS (altitudes above mean sea
# level, the take-off altitude from DJI's XMP), undistort at SIZE px.
step align "$out/aligned" "$vpctl" colmap align --colmap "$model" --exif "$photos" --out "$out/aligned"
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
# accuracy the 40 m grid nearly gives, 5 m from the reconstructed surface.
# Space no photo observed counts as free (the paper's rule, not vpctl's
# default "occupied"): the first photos of the Brighton flight look down on
# a tree canopy, where dense stereo keeps a depth on 0-10 % of the pixels,
# and with unobserved space as an obstacle the take-off point there has no
# clear way up.
# The take-off point: where `colmap align --exif` found DJI's take-off
# altitude (GPS altitude less the XMP's RelativeAltitude, in frame.json),
# at that altitude below the first photo (photos do not record where the
# drone took off: fly with --home where you stand instead) -- on Brighton
# the mesh has no surface below the first photo (the canopy); without that
# altitude, on the mesh below the first photo.
home=(--home-from-first-image)
frame="$out/aligned/frame.json"
takeoff=$(awk -F': *' '/"takeoff_alt_m"/ {gsub(/[ ,]/, "", $2); print $2}' "$frame")
if [ -n "$takeoff" ] && [ "$takeoff" != null ]; then
  lat=$(awk -F': *' '/"lat_deg"/ {gsub(/[ ,]/, "", $2); print $2; exit}' "$frame")
  lon=$(awk -F': *' '/"lon_deg"/ {gsub(/[ ,]/, "", $2); print $2; exit}' "$frame")
  datum=$(awk -F': *' '/"vertical_datum"/ {gsub(/[ ,"]/, "", $2); print $2}' "$frame")
  home=(--home "$lat,$lon,$takeoff${datum:+,$datum}")
  echo "home: ${home[1]} (first photo's position, DJI's take-off altitude)"
fi
plan_config="${PLAN_CONFIG:-$out/plan.toml}"
if [ -z "${PLAN_CONFIG:-}" ]; then
  cat >"$plan_config" <<'EOF'
gsd_m = 0.01
accuracy_m = 0.02
safety_distance_m = 5.0
unknown_space = "free"
[camera]
width = 4000
height = 2250
focal_px = 2985.0
EOF
fi
step plan "$out/plan.json" "$vpctl" plan --mesh "$out/site.ply" --colmap "$out/dense/sparse" \
  --confidence-dir "$out/conf" --config "$plan_config" "${home[@]}" \
  --out "$out/plan.json" --glb "$out/plan.glb"
step export-plan "$out/mission.plan" "$vpctl" mission export "$out/plan.json" --out "$out/mission.plan"
step export-kmz "$out/mission.kmz" "$vpctl" mission export "$out/plan.json" --out "$out/mission.kmz" --drone m3e

# 5. Optional (BRIGHTON_OWN_FOREST=1; off by default, it costs about 6
# times the `mvs` step's CPU at 800 px, training most): Brighton's own forest, trained on its own triplets
# (the README's labelgen chain), and both forests scored with `vpctl forest
# eval` on labels of photos the own forest never saw. The split is spatial:
# HELDOUT (default the six photos of the flight's north-east third, more
# than 45 m along the flight lines from the first photo) against the other
# twelve. Each side gets its own sub-model (COLMAP's image_deleter, same
# frame.json), so every triplet, and so every label, lies on one side.
if [ "${BRIGHTON_OWN_FOREST:-0}" = 1 ]; then
  heldout="${HELDOUT:-DJI_0022.JPG,DJI_0023.JPG,DJI_0024.JPG,DJI_0025.JPG,DJI_0034.JPG,DJI_0035.JPG}"
  own="$out/own-forest"
  mkdir -p "$own/train" "$own/heldout"
  tr ',' '\n' <<<"$heldout" >"$own/heldout.txt"
  (cd "$out/dense/images" && printf '%s\n' *) | grep -vxF -f "$own/heldout.txt" >"$own/train.txt"
  for side in train heldout; do
    # image_deleter removes the listed photos: each side's model drops the other's.
    other=heldout
    if [ "$side" = heldout ]; then other=train; fi
    colmap image_deleter --input_path "$out/dense/sparse" --output_path "$own/$side" \
      --image_names_path "$own/$other.txt" >"$out/logs/split-$side.log" 2>&1
    cp "$out/dense/sparse/frame.json" "$own/$side/"
    step "triplets-$side" "$own/$side-triplets.txt" "$vpctl" labelgen triplets \
      --colmap "$own/$side" --out "$own/$side-triplets.txt"
    step "mvs-$side" "$own/depth-$side" "$vpctl" mvs run --workspace "$out/dense" "${mvs_config[@]}" \
      --triplets "$own/$side-triplets.txt" --levels 1,2,3 --out "$own/depth-$side"
    step "labels-$side" "$own/labels-$side" "$vpctl" labelgen run --colmap "$own/$side" \
      --triplets "$own/$side-triplets.txt" --depth-dir "$own/depth-$side" --out "$own/labels-$side"
  done
  step train-own "$own/brighton.vpforest" "$vpctl" train --images "$out/dense/images" \
    --labels "$own/labels-train" --out "$own/brighton.vpforest"
  for f in "$forest" "$own/brighton.vpforest"; do
    echo "forest eval on the held-out labels ($(tr '\n' ' ' <"$own/heldout.txt")): $f"
    "$vpctl" forest eval --forest "$f" --images "$out/dense/images" --labels "$own/labels-heldout" |
      tee "$own/eval-$(basename "$f" .vpforest).txt"
  done
fi

total=$(awk -F'\t' 'NR > 1 {w += $2; c += $3} END {printf "%.1f s wall, %.1f s CPU", w, c}' "$log")
echo "total: $total at $size px; steps in $log"
