#!/usr/bin/env python3
"""Agreement of dense depth maps (COLMAP's format) with COLMAP's sparse
points on a real sequence (default: tests/data/real-mvs/visp-cube): a
reference implementation, in Python, of the score the issue asks of vp-mvs
on real photos (median relative depth error <= 1 %, >= 80 % of points within
2 %), to check a Rust test against.

    .venv/bin/pip install -r benches/peer/requirements-mvs.txt
    .venv/bin/python benches/peer/sparse_agreement.py --run-vpctl [--min-angle 10 --max-error 1]
    # or depth maps made otherwise:
    .venv/bin/python benches/peer/sparse_agreement.py --workspace WS --depth-maps WS/stereo/depth_maps

For every image with a depth map and every sparse point the image observes
(filtered: seen in >= --min-track distinct images, reprojection error <=
--max-error px, largest triangulation angle between its images' rays >=
--min-angle deg), the point is projected into the image (COLMAP pixel
convention: pixel (i, j) covers [i, i+1) x [j, j+1)); the depth map's value
at that pixel is compared with the point's camera-z depth:
relative error = |z_map - z_point| / z_point. A pixel without depth counts
as a miss (error infinite). Prints per image and overall: points scored,
share with a depth, median relative error (over all scored points, misses
included), share within 1 % and 2 %. The geometric map is used where both
exist.
"""
import argparse
import math
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def qrot(q):
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def data_lines(path):
    with open(path) as fh:
        return [l for l in fh.read().splitlines() if not l.startswith("#")]


def read_model(sparse):
    cams = {}
    for l in data_lines(os.path.join(sparse, "cameras.txt")):
        w = l.split()
        if not w:
            continue
        model, width, height, p = w[1], int(w[2]), int(w[3]), [float(v) for v in w[4:]]
        if model == "PINHOLE":
            fx, fy, cx, cy = p
        elif model == "SIMPLE_PINHOLE":
            fx = fy = p[0]
            cx, cy = p[1], p[2]
        else:
            sys.exit(f"{sparse}/cameras.txt: camera {w[0]} is {model}; undistort first (PINHOLE expected)")
        cams[int(w[0])] = (width, height, np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]))
    images = {}
    lines = data_lines(os.path.join(sparse, "images.txt"))
    for i in range(0, len(lines) - 1, 2):
        w = lines[i].split()
        if not w:
            continue
        R = qrot([float(v) for v in w[1:5]])
        t = np.array([float(v) for v in w[5:8]])
        images[w[9]] = dict(id=int(w[0]), R=R, t=t, C=-R.T @ t, cam=cams[int(w[8])])
    by_id = {v["id"]: v for v in images.values()}
    points = []
    for l in data_lines(os.path.join(sparse, "points3D.txt")):
        w = l.split()
        if not w:
            continue
        X = np.array([float(v) for v in w[1:4]])
        ids = sorted(set(int(v) for v in w[8::2]))
        rays = [(by_id[i]["C"] - X) / np.linalg.norm(by_id[i]["C"] - X) for i in ids]
        ang = 0.0
        for a in range(len(rays)):
            for b in range(a + 1, len(rays)):
                ang = max(ang, math.degrees(math.acos(max(-1.0, min(1.0, float(rays[a] @ rays[b]))))))
        points.append(dict(X=X, ids=set(ids), err=float(w[7]), angle=ang))
    return images, points


def read_depth(path):
    with open(path, "rb") as fh:
        data = fh.read()
    dims, pos = [], 0
    for _ in range(3):
        end = data.index(b"&", pos)
        dims.append(int(data[pos:end].strip()))
        pos = end + 1
    w, h, c = dims
    return np.frombuffer(data, dtype="<f4", count=w * h * c, offset=pos).reshape(c, h, w)[0]


def score_image(img, depth, points, args):
    errs = []
    h, w = depth.shape
    K = img["cam"][2]
    for p in points:
        if img["id"] not in p["ids"] or len(p["ids"]) < args.min_track:
            continue
        if p["err"] > args.max_error or p["angle"] < args.min_angle:
            continue
        Xc = img["R"] @ p["X"] + img["t"]
        if Xc[2] <= 0:
            continue
        u = K[0, 0] * Xc[0] / Xc[2] + K[0, 2]
        v = K[1, 1] * Xc[1] / Xc[2] + K[1, 2]
        i, j = int(math.floor(u)), int(math.floor(v))
        if not (0 <= i < w and 0 <= j < h):
            continue
        z = float(depth[j, i])
        errs.append(abs(z - Xc[2]) / Xc[2] if (z > 0 and math.isfinite(z)) else math.inf)
    return np.array(errs)


def summary(errs):
    if len(errs) == 0:
        return "no points"
    fin = np.isfinite(errs)
    return (f"{len(errs):5d} points, with depth {100 * fin.mean():5.1f} %, median rel. error "
            f"{100 * np.median(errs):6.2f} %, within 1 % {100 * (errs <= 0.01).mean():5.1f} %, "
            f"within 2 % {100 * (errs <= 0.02).mean():5.1f} %")


def run_vpctl(args):
    import shutil
    import subprocess
    import tempfile
    import time

    vpctl = args.run_vpctl or os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")),
                                           "release", "vpctl")
    if not os.path.exists(vpctl):
        sys.exit(f"vp-mvs NOT RUN: {vpctl} does not exist (cargo build --release -p vpctl)")
    r = subprocess.run([vpctl, "mvs", "run", "--help"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"vp-mvs NOT RUN: `vpctl mvs run` is not available in this build "
                 f"({(r.stderr or r.stdout).strip().splitlines()[0]})")
    ws = os.path.join(tempfile.mkdtemp(prefix="sparse_agreement_"), "ws")
    shutil.copytree(args.workspace, ws)
    cmd = [vpctl, "mvs", "run", "--workspace", ws]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed (exit {r.returncode}):\n{r.stderr[-2000:]}")
    print(f"ran: {' '.join(cmd)}  [{time.perf_counter() - t0:.1f} s]")
    return os.path.join(ws, "stereo", "depth_maps")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workspace", default=os.path.join(ROOT, "tests", "data", "real-mvs", "visp-cube"))
    ap.add_argument("--depth-maps", help="folder of <image>.geometric.bin / .photometric.bin to score")
    ap.add_argument("--run-vpctl", nargs="?", const="", default=None, metavar="VPCTL",
                    help="copy the workspace to a temporary folder, run `VPCTL mvs run --workspace` on it "
                         "(default binary target/release/vpctl) and score its depth maps")
    ap.add_argument("--min-track", type=int, default=3)
    ap.add_argument("--max-error", type=float, default=2.0)
    ap.add_argument("--min-angle", type=float, default=0.0)
    args = ap.parse_args()
    if args.run_vpctl is not None:
        args.depth_maps = run_vpctl(args)
    if not args.depth_maps:
        sys.exit("nothing to score: give --depth-maps DIR or --run-vpctl")

    images, points = read_model(os.path.join(args.workspace, "sparse"))
    for n, im in images.items():
        im["name"] = n
    print(f"model {args.workspace}/sparse: {len(images)} images, {len(points)} points; "
          f"filter: track >= {args.min_track}, error <= {args.max_error} px, angle >= {args.min_angle} deg")
    all_errs = []
    for n in sorted(images):
        for kind in ("geometric", "photometric"):
            p = os.path.join(args.depth_maps, f"{n}.{kind}.bin")
            if os.path.exists(p):
                errs = score_image(images[n], read_depth(p), points, args)
                print(f"  {n} ({kind}): {summary(errs)}")
                all_errs.append(errs)
                break
    if not all_errs:
        sys.exit(f"no depth map of any model image under {args.depth_maps}")
    print(f"overall: {summary(np.concatenate(all_errs))}")


if __name__ == "__main__":
    main()
