#!/bin/sh
# Regenerates the COLMAP-written test data in this folder (see README.md).
# Needs: colmap on PATH (Debian 12 package, COLMAP 3.8, no CUDA) and a python3
# with numpy, pillow and scikit-image (PYTHON=... to choose it).
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
PYTHON=${PYTHON:-python3}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# 1. Hand model: hand/vpctl_txt is written by vp-scene's text writer
#    (cargo test -p vp-scene --test colmap_real -- --ignored regenerate).
#    COLMAP converts it to binary, and its binary back to text.
rm -rf "$HERE/hand/colmap_bin" "$HERE/hand/colmap_txt"
mkdir -p "$HERE/hand/colmap_bin" "$HERE/hand/colmap_txt"
colmap model_converter --input_path "$HERE/hand/vpctl_txt" \
    --output_path "$HERE/hand/colmap_bin" --output_type BIN
colmap model_converter --input_path "$HERE/hand/colmap_bin" \
    --output_path "$HERE/hand/colmap_txt" --output_type TXT

# 2. A real SfM run on four rendered views.
"$PYTHON" "$HERE/render_views.py" "$WORK/images"
colmap feature_extractor --database_path "$WORK/db.db" --image_path "$WORK/images" \
    --ImageReader.camera_model SIMPLE_PINHOLE --ImageReader.single_camera 1 \
    --SiftExtraction.use_gpu 0 --SiftExtraction.max_num_features 300
colmap exhaustive_matcher --database_path "$WORK/db.db" --SiftMatching.use_gpu 0
mkdir -p "$WORK/sparse"
colmap mapper --database_path "$WORK/db.db" --image_path "$WORK/images" \
    --output_path "$WORK/sparse"
rm -rf "$HERE/sfm/bin" "$HERE/sfm/txt"
mkdir -p "$HERE/sfm/bin" "$HERE/sfm/txt"
cp "$WORK/sparse/0/cameras.bin" "$WORK/sparse/0/images.bin" "$WORK/sparse/0/points3D.bin" \
    "$HERE/sfm/bin/"
colmap model_converter --input_path "$HERE/sfm/bin" --output_path "$HERE/sfm/txt" \
    --output_type TXT

# 3. A depth map in COLMAP's dense layout (COLMAP's patch_match_stereo needs
#    CUDA, so this one is written with numpy the way read_write_dense.py does).
mkdir -p "$HERE/depth"
"$PYTHON" - "$HERE/depth/ramp_5x3.geometric.bin" <<'PY'
import sys
import numpy as np
h, w = 3, 5
y, x = np.mgrid[0:h, 0:w]
depth = (1 + x + 10 * y).astype(np.float32)
depth[x == y] = 0
with open(sys.argv[1], "wb") as f:
    f.write(f"{w}&{h}&1&".encode())
    # read_write_dense.py: transpose to (w, h), flatten in Fortran order.
    f.write(np.transpose(depth, (1, 0)).reshape(-1, order="F").astype("<f4").tobytes())
PY
