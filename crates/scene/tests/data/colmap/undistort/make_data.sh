#!/bin/sh
# Regenerates this folder (see README.md). Needs colmap on PATH (COLMAP 3.8,
# Debian 12) and a python3 with numpy, pillow and scikit-image (PYTHON=...).
set -eu
cd "$(dirname "$0")"
PY=${PYTHON:-python3}
rm -rf input colmap work
mkdir -p input/images input/model
"$PY" - <<'PYEOF'
import numpy as np
from PIL import Image
from skimage import data, transform
img = data.astronaut()  # NASA photo, public domain; 512x512 RGB
small = (transform.resize(img[40:400, 20:500], (120, 160), anti_aliasing=True) * 255).round().astype(np.uint8)
cams = [
    ("SIMPLE_PINHOLE", [130, 80, 60]),
    ("PINHOLE", [130, 135, 81.2, 59.4]),
    ("SIMPLE_RADIAL", [130, 80.5, 60.2, -0.12]),
    ("RADIAL", [130, 79.6, 60.8, -0.1, 0.03]),
    ("OPENCV", [128, 131, 81, 59, -0.09, 0.02, 0.002, -0.001]),
    ("OPENCV_FISHEYE", [110, 111, 80, 60, 0.05, -0.02, 0.01, -0.005]),
    ("FULL_OPENCV", [128, 131, 81, 59, -0.1, 0.03, 0.001, -0.002, -0.005, 0.02, 0.01, 0.001]),
    ("FOV", [120, 121, 80, 60, 0.6]),
    ("SIMPLE_RADIAL_FISHEYE", [110, 80, 60, 0.04]),
    ("RADIAL_FISHEYE", [110, 80, 60, 0.04, -0.01]),
    ("THIN_PRISM_FISHEYE", [110, 112, 80, 60, 0.04, -0.01, 0.001, -0.001, 0.002, -0.001, 0.001, -0.0005]),
]
with open("input/model/cameras.txt", "w") as f:
    for i, (m, p) in enumerate(cams):
        f.write(f"{i+1} {m} 160 120 " + " ".join(repr(float(x)) for x in p) + "\n")
pts = [(0.5, 0.5), (80, 60), (159.5, 119.5), (10.25, 100.75), (150, 5)]
with open("input/model/images.txt", "w") as f:
    for i, (m, p) in enumerate(cams):
        name = f"m{i:02d}_{m.lower()}.png"
        Image.fromarray(small).save("input/images/" + name)
        f.write(f"{i+1} 1 0 0 0 0.{i} 0 0 {i+1} {name}\n")
        f.write(" ".join(f"{x} {y} -1" for x, y in pts) + "\n")
open("input/model/points3D.txt", "w").close()
PYEOF
export QT_QPA_PLATFORM=offscreen
colmap image_undistorter --image_path input/images --input_path input/model \
  --output_path work --output_type COLMAP
mkdir -p colmap/sparse
colmap model_converter --input_path work/sparse --output_path colmap/sparse --output_type TXT
mv work/images colmap/images
cp work/stereo/patch-match.cfg work/stereo/fusion.cfg colmap/
rm -rf work
