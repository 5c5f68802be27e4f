#!/usr/bin/env python3
"""Dense stereo accuracy of vp-mvs against OpenCV's StereoSGBM, in one run,
on a real rectified pair with ground-truth disparity and on a rendered pair.

    python3 -m venv .venv && .venv/bin/pip install -r benches/peer/requirements-mvs.txt
    cargo build --release -p vpctl
    apt-get install opencv-doc   # the Aloe pair (optional)
    .venv/bin/python benches/peer/mvs_vs_sgbm.py [--pairs motorcycle,aloe,rendered] [--keep DIR]

Pairs:
- motorcycle: Middlebury 2014 "Motorcycle" (Scharstein et al., GCPR 2014),
  quarter size (741x500), left/right images and the left ground-truth
  disparity, as shipped inside the scikit-image wheel
  (`skimage.data.stereo_motorcycle()`, no download). Calibration from its
  docstring: f = 994.978 px, doffs = 31.086 px, baseline = 193.001 mm.
- aloe: Middlebury 2006 "Aloe", left/right JPEGs and the 8-bit left
  ground-truth disparity as shipped by Debian's opencv-doc
  (/usr/share/doc/opencv-doc/examples/data; `apt-get install opencv-doc`),
  downsampled to half size by default; no calibration ships with it, so an
  arbitrary f, B (d = f B / Z) is used, which changes no correspondence.
  Skipped with a message when opencv-doc is not installed.
- rendered: two views of a procedural site rendered by `vpctl sim render`
  (exact depth), the right camera moved by --baseline metres along the left
  camera's x axis with the same orientation: a rectified pair whose
  ground-truth disparity is f * B / Z of the left depth.

Score (Middlebury's "bad 2.0, all", turned around): the share of
ground-truth pixels (finite disparity whose match x - d lies inside the right
image) where the method gives a disparity within 2 px of the truth; pixels
where a method gives none count as misses. Also printed: density (share of GT
pixels with an estimate) and the share within 2 px among the estimates.
Both methods search the same disparity interval: the ground truth's range
widened by --margin px (SGBM: minDisparity/numDisparities; vp-mvs: the
matching depth range, passed as --depth-range).

vp-mvs runs through its CLI on a COLMAP dense workspace that this script
writes (two PINHOLE cameras, identity rotations, the right camera at +B along
x; sparse/ in text with an empty points3D.txt; stereo/patch-match.cfg
pairing the two images):
    vpctl mvs run --workspace DIR --depth-range MIN,MAX
and reads stereo/depth_maps/left.png.geometric.bin (or .photometric.bin),
COLMAP's format (ASCII "W&H&C&", then little-endian float32, row-major,
channel after channel); disparity = f * B / Z - doffs. Where `vpctl mvs`
does not exist yet the script says so and reports SGBM alone.
"""
import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def vpctl_path(arg):
    if arg:
        return arg
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "release", "vpctl")


# ---------------------------------------------------------------- pairs

class Pair:
    """A rectified pair: left/right images (HxWx3 uint8), the left GT
    disparity (NaN/inf where none), the focal length f (px), the baseline B
    (m), the principal points' x offset doffs (px, cx_right - cx_left),
    the left principal point, and optionally an occlusion mask."""

    def __init__(self, name, left, right, gt, f, baseline, cx, cy, doffs, nonocc=None, note=""):
        self.name, self.left, self.right, self.gt = name, left, right, gt
        self.f, self.baseline, self.cx, self.cy, self.doffs = f, baseline, cx, cy, doffs
        self.nonocc, self.note = nonocc, note


def load_motorcycle():
    import skimage
    from skimage.data import stereo_motorcycle

    left, right, gt = stereo_motorcycle()
    # Middlebury/skimage principal points are in pixel-index coordinates
    # (pixel centres at integers); COLMAP's at +0.5. Only cx_r - cx_l
    # enters the disparity.
    return Pair("motorcycle", left, right, gt.astype(np.float64),
                f=994.978, baseline=0.193001, cx=311.193 + 0.5, cy=254.877 + 0.5, doffs=31.086,
                note=f"Middlebury 2014 Motorcycle, quarter size, from scikit-image {skimage.__version__}")


OPENCV_DATA = "/usr/share/doc/opencv-doc/examples/data"


def load_aloe(scale):
    """Middlebury 2006 "Aloe" (Hirschmueller & Scharstein, CVPR 2007), full
    size 1282x1110, as shipped by Debian's opencv-doc in its samples data:
    aloeL.jpg / aloeR.jpg (JPEG) and aloeGT.png (8-bit left disparity in
    pixels, 0 = unknown). No calibration ships with it: any f and B with
    d = f B / Z describe the same rectified pair (a projective change of the
    3D frame leaves every correspondence unchanged), so f = 1000 px and
    B = 1 are used; doffs = 0. `scale` < 1 downsamples by area averaging and
    scales the disparities with it."""
    import cv2

    paths = [os.path.join(OPENCV_DATA, n) for n in ("aloeL.jpg", "aloeR.jpg", "aloeGT.png")]
    missing = [p for p in paths if not os.path.exists(p)]
    if missing:
        raise FileNotFoundError(f"{missing[0]} is missing (apt-get install opencv-doc)")
    left, right = (read_png(p) for p in paths[:2])
    gt8 = cv2.imread(paths[2], cv2.IMREAD_GRAYSCALE).astype(np.float64)
    gt = np.where(gt8 > 0, gt8, np.nan)
    if scale != 1.0:
        h, w = gt.shape
        size = (int(round(w * scale)), int(round(h * scale)))
        left = cv2.resize(left, size, interpolation=cv2.INTER_AREA)
        right = cv2.resize(right, size, interpolation=cv2.INTER_AREA)
        # Nearest GT sample (no mixing across depth edges), disparity scaled.
        gt = cv2.resize(gt, size, interpolation=cv2.INTER_NEAREST) * scale
    h, w = gt.shape
    return Pair("aloe", left, right, gt, f=1000.0, baseline=1.0, cx=0.5 * w, cy=0.5 * h, doffs=0.0,
                note=f"Middlebury 2006 Aloe from Debian opencv-doc ({OPENCV_DATA}), scale {scale}")


def read_colmap_depth(path):
    """A COLMAP depth/normal map: (channels, height, width) float32."""
    with open(path, "rb") as fh:
        data = fh.read()
    dims, pos = [], 0
    for _ in range(3):
        end = data.index(b"&", pos)
        dims.append(int(data[pos:end].strip()))
        pos = end + 1
    w, h, c = dims
    arr = np.frombuffer(data, dtype="<f4", count=w * h * c, offset=pos)
    return arr.reshape(c, h, w)


def read_png(path):
    import cv2

    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None:
        raise RuntimeError(f"cannot read {path}")
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


def render_pair(vpctl, tmp, args):
    """Left and right views of a procedural site with exact depth."""
    frm = np.array([float(v) for v in args.render_from.split(",")])
    at = np.array([float(v) for v in args.render_at.split(",")])
    z = at - frm
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])  # vp-scene's look_at: x = z cross up
    x /= np.linalg.norm(x)
    w, h = args.render_size
    out = {}
    for side, shift in (("left", 0.0), ("right", args.baseline)):
        c, t = frm + shift * x, at + shift * x
        img, dep = os.path.join(tmp, f"r_{side}.png"), os.path.join(tmp, f"r_{side}.bin")
        cmd = [vpctl, "sim", "render", "--seed", str(args.seed), "--faces", str(args.faces),
               "--from", ",".join(f"{v:.6f}" for v in c), "--at", ",".join(f"{v:.6f}" for v in t),
               "--width", str(w), "--height", str(h), "--hfov", str(args.hfov),
               "--out", img, "--depth", dep, "--force"]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        out[side] = (read_png(img), read_colmap_depth(dep)[0].astype(np.float64))
    f = 0.5 * w / math.tan(math.radians(0.5 * args.hfov))
    zl, zr = out["left"][1], out["right"][1]
    gt = np.full(zl.shape, np.nan)
    hit = (zl > 0) & np.isfinite(zl)
    gt[hit] = f * args.baseline / zl[hit]
    # Visible in the right view: the right depth at x - d agrees with the
    # left depth (the same point lies at the same camera z in both views).
    ys, xs = np.nonzero(hit)
    xr = np.floor(xs + 0.5 - gt[ys, xs]).astype(int)  # pixel centres at +0.5
    inside = (xr >= 0) & (xr < w)
    nonocc = np.zeros(zl.shape, bool)
    zr_at = zr[ys[inside], xr[inside]]
    ok = np.abs(zr_at - zl[ys[inside], xs[inside]]) <= 0.01 * zl[ys[inside], xs[inside]]
    nonocc[ys[inside][ok], xs[inside][ok]] = True
    return Pair("rendered", out["left"][0], out["right"][0], gt, f=f, baseline=args.baseline,
                cx=0.5 * w, cy=0.5 * h, doffs=0.0, nonocc=nonocc,
                note=f"vpctl sim render seed {args.seed}, {args.faces} faces, {w}x{h}, hfov {args.hfov}, "
                     f"baseline {args.baseline} m")


# ---------------------------------------------------------------- methods

def search_range(pair, margin):
    g = pair.gt[np.isfinite(pair.gt) & (pair.gt > 0)]
    lo = max(0, int(math.floor(g.min())) - margin)
    hi = int(math.ceil(g.max())) + margin
    return lo, hi


def run_sgbm(pair, lo, hi, args):
    import cv2

    cn = 3
    bs = args.block_size
    num = int(math.ceil((hi - lo) / 16.0)) * 16
    mode = {"3way": cv2.StereoSGBM_MODE_SGBM_3WAY, "hh": cv2.StereoSGBM_MODE_HH,
            "sgbm": cv2.StereoSGBM_MODE_SGBM}[args.sgbm_mode]
    sgbm = cv2.StereoSGBM_create(
        minDisparity=lo, numDisparities=num, blockSize=bs,
        P1=8 * cn * bs * bs, P2=32 * cn * bs * bs, disp12MaxDiff=1,
        preFilterCap=63, uniquenessRatio=10, speckleWindowSize=100, speckleRange=2, mode=mode)
    left = cv2.cvtColor(pair.left, cv2.COLOR_RGB2BGR)
    right = cv2.cvtColor(pair.right, cv2.COLOR_RGB2BGR)
    t0 = time.perf_counter()
    raw = sgbm.compute(left, right)
    dt = time.perf_counter() - t0
    disp = raw.astype(np.float64) / 16.0
    disp[raw < lo * 16] = np.nan  # invalid: minDisparity - 1 (times 16)
    params = (f"mode={args.sgbm_mode} minDisparity={lo} numDisparities={num} blockSize={bs} "
              f"P1={8 * cn * bs * bs} P2={32 * cn * bs * bs} disp12MaxDiff=1 preFilterCap=63 "
              f"uniquenessRatio=10 speckleWindowSize=100 speckleRange=2")
    return disp, dt, params


def mvs_available(vpctl):
    if not os.path.exists(vpctl):
        return False, f"{vpctl} does not exist (cargo build --release -p vpctl)"
    r = subprocess.run([vpctl, "mvs", "run", "--help"], capture_output=True, text=True)
    if r.returncode != 0:
        first = (r.stderr or r.stdout).strip().splitlines()
        return False, f"`vpctl mvs run` is not available in this build ({first[0] if first else 'exit %d' % r.returncode})"
    return True, ""


def write_workspace(pair, ws):
    import cv2

    os.makedirs(os.path.join(ws, "images"))
    os.makedirs(os.path.join(ws, "sparse"))
    os.makedirs(os.path.join(ws, "stereo"))
    h, w = pair.gt.shape
    for name, img in (("left.png", pair.left), ("right.png", pair.right)):
        cv2.imwrite(os.path.join(ws, "images", name), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    with open(os.path.join(ws, "sparse", "cameras.txt"), "w") as fh:
        fh.write("# Camera list with one line of data per camera:\n"
                 "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n# Number of cameras: 2\n")
        fh.write(f"1 PINHOLE {w} {h} {pair.f!r} {pair.f!r} {pair.cx!r} {pair.cy!r}\n")
        fh.write(f"2 PINHOLE {w} {h} {pair.f!r} {pair.f!r} {pair.cx + pair.doffs!r} {pair.cy!r}\n")
    with open(os.path.join(ws, "sparse", "images.txt"), "w") as fh:
        fh.write("# Image list with two lines of data per image:\n"
                 "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
                 "#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Number of images: 2, mean observations per image: 0\n")
        # World = left camera frame; the right camera centre is at (+B, 0, 0),
        # so its world-to-camera translation is -R C = (-B, 0, 0).
        fh.write("1 1 0 0 0 0 0 0 1 left.png\n\n")
        fh.write(f"2 1 0 0 0 {-pair.baseline!r} 0 0 2 right.png\n\n")
    with open(os.path.join(ws, "sparse", "points3D.txt"), "w") as fh:
        fh.write("# 3D point list with one line of data per point:\n"
                 "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                 "# Number of points: 0, mean track length: 0\n")
    with open(os.path.join(ws, "stereo", "patch-match.cfg"), "w") as fh:
        fh.write("left.png\nright.png\nright.png\nleft.png\n")


def run_mvs(pair, lo, hi, vpctl, ws, extra):
    write_workspace(pair, ws)
    # Disparity interval [lo, hi] -> depth interval; d + doffs > 0 always here.
    zmin = pair.f * pair.baseline / (hi + pair.doffs)
    zmax = pair.f * pair.baseline / max(lo + pair.doffs, 1e-3)
    cmd = [vpctl, "mvs", "run", "--workspace", ws, "--depth-range", f"{zmin:.6g},{zmax:.6g}"] + extra
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {r.returncode}):\n{r.stderr[-2000:]}")
    out = {}
    for kind in ("geometric", "photometric"):
        p = os.path.join(ws, "stereo", "depth_maps", f"left.png.{kind}.bin")
        if os.path.exists(p):
            z = read_colmap_depth(p)[0].astype(np.float64)
            if z.shape != pair.gt.shape:
                raise RuntimeError(f"{p}: {z.shape[1]}x{z.shape[0]}, expected {pair.gt.shape[1]}x{pair.gt.shape[0]}")
            d = np.full(z.shape, np.nan)
            ok = (z > 0) & np.isfinite(z)
            d[ok] = pair.f * pair.baseline / z[ok] - pair.doffs
            out[kind] = d
    if not out:
        raise RuntimeError(f"{' '.join(cmd)} wrote no depth map for left.png under {ws}/stereo/depth_maps")
    return out, dt, " ".join(cmd[1:])


# ---------------------------------------------------------------- score

def score(pair, disp, mask_extra=None):
    gt = pair.gt
    h, w = gt.shape
    xs = np.arange(w)[None, :]
    valid = np.isfinite(gt) & (gt > 0) & (xs - gt >= 0)
    if mask_extra is not None:
        valid &= mask_extra
    est = np.isfinite(disp)
    good = valid & est & (np.abs(disp - gt) <= 2.0)
    n = int(valid.sum())
    n_est = int((valid & est).sum())
    return {
        "n": n,
        "within2": good.sum() / n,
        "density": n_est / n,
        "within2_of_est": good.sum() / max(n_est, 1),
    }


def fmt(s):
    return (f"{100 * s['within2']:6.2f} %  (density {100 * s['density']:5.1f} %, "
            f"within 2 px of estimates {100 * s['within2_of_est']:5.1f} %)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", default="motorcycle,aloe,rendered")
    ap.add_argument("--aloe-scale", type=float, default=0.5, help="downsampling of the Aloe pair (1 = full 1282x1110)")
    ap.add_argument("--vpctl", default=None, help="vpctl binary (default target/release/vpctl)")
    ap.add_argument("--mvs-arg", action="append", default=[], help="extra argument for `vpctl mvs run` (repeat)")
    ap.add_argument("--margin", type=int, default=4, help="px added to each side of the GT disparity range")
    ap.add_argument("--sgbm-mode", choices=["3way", "hh", "sgbm"], default="3way")
    ap.add_argument("--block-size", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--faces", type=int, default=200_000)
    ap.add_argument("--render-size", type=lambda s: tuple(int(v) for v in s.split("x")), default=(640, 480))
    ap.add_argument("--render-from", default="-30,-25,30")
    ap.add_argument("--render-at", default="0,0,0")
    ap.add_argument("--hfov", type=float, default=60.0)
    ap.add_argument("--baseline", type=float, default=3.0, help="rendered pair baseline, metres")
    ap.add_argument("--keep", default=None, help="keep the workspaces and maps in this folder")
    args = ap.parse_args()

    import cv2

    vpctl = vpctl_path(args.vpctl)
    have_mvs, why = mvs_available(vpctl)
    tmp = args.keep or tempfile.mkdtemp(prefix="mvs_vs_sgbm_")
    os.makedirs(tmp, exist_ok=True)
    print(f"opencv {cv2.__version__}, numpy {np.__version__}; vpctl {vpctl}")
    if not have_mvs:
        print(f"vp-mvs NOT RUN: {why}. Reporting StereoSGBM only.")

    rows = []
    for name in [p.strip() for p in args.pairs.split(",") if p.strip()]:
        if name == "motorcycle":
            pair = load_motorcycle()
        elif name == "aloe":
            try:
                pair = load_aloe(args.aloe_scale)
            except FileNotFoundError as e:
                print(f"aloe pair SKIPPED: {e}")
                continue
        elif name == "rendered":
            if not os.path.exists(vpctl):
                print(f"rendered pair SKIPPED: {vpctl} does not exist (cargo build --release -p vpctl)")
                continue
            pair = render_pair(vpctl, tmp, args)
        else:
            sys.exit(f"unknown pair {name!r} (motorcycle, aloe, rendered)")
        h, w = pair.gt.shape
        lo, hi = search_range(pair, args.margin)
        print(f"\n== {pair.name}: {w}x{h}, {pair.note}")
        print(f"   disparity search [{lo}, {hi}] px (GT range +- {args.margin} px), f {pair.f:.3f} px, "
              f"B {pair.baseline} m, doffs {pair.doffs} px")
        masks = [("all", None)] + ([("nonocc", pair.nonocc)] if pair.nonocc is not None else [])
        sg, t_sg, params = run_sgbm(pair, lo, hi, args)
        print(f"   SGBM: {params}  [{t_sg:.2f} s]")
        res = {}
        for mname, m in masks:
            res[("sgbm", mname)] = score(pair, sg, m)
        if args.keep:
            np.save(os.path.join(tmp, f"{pair.name}_sgbm.npy"), sg.astype(np.float32))
            np.save(os.path.join(tmp, f"{pair.name}_gt.npy"), pair.gt.astype(np.float32))
        mvs = None
        if have_mvs:
            ws = os.path.join(tmp, f"ws_{pair.name}")
            if os.path.exists(ws):
                shutil.rmtree(ws)
            try:
                maps, t_mvs, cmd = run_mvs(pair, lo, hi, vpctl, ws, args.mvs_arg)
                kind = "geometric" if "geometric" in maps else "photometric"
                mvs = maps[kind]
                print(f"   vp-mvs: vpctl {cmd}  [{t_mvs:.2f} s], scoring the {kind} map")
                for mname, m in masks:
                    res[("mvs", mname)] = score(pair, mvs, m)
                    for other in maps:
                        if other != kind:
                            res[(f"mvs-{other}", mname)] = score(pair, maps[other], m)
            except RuntimeError as e:
                print(f"   vp-mvs FAILED: {e}")
        for mname, _ in masks:
            s = res[("sgbm", mname)]
            print(f"   [{mname}, {s['n']} GT px] share within 2 px:")
            print(f"     StereoSGBM          {fmt(s)}")
            for key, label in (("mvs", "vp-mvs"), ("mvs-photometric", "vp-mvs (photometric)"),
                               ("mvs-geometric", "vp-mvs (geometric)")):
                if (key, mname) in res:
                    print(f"     {label:<19} {fmt(res[(key, mname)])}")
            if ("mvs", mname) in res:
                m = res[("mvs", mname)]
                ratio = m["within2"] / s["within2"] if s["within2"] > 0 else float("inf")
                print(f"     vp-mvs / SGBM       {ratio:.3f}  ({'meets' if ratio >= 1 else 'below'} the target vp-mvs >= SGBM)")
                rows.append((pair.name, mname, s["within2"], m["within2"], ratio))
            else:
                rows.append((pair.name, mname, s["within2"], None, None))

    print("\nsummary (share of GT pixels within 2 px):")
    print(f"  {'pair':<11} {'pixels':<7} {'SGBM':>8} {'vp-mvs':>8} {'ratio':>7}")
    for name, mname, s, m, ratio in rows:
        ms = f"{100 * m:7.2f}%" if m is not None else "  not run"
        rs = f"{ratio:7.3f}" if ratio is not None else "      -"
        print(f"  {name:<11} {mname:<7} {100 * s:7.2f}% {ms:>8} {rs}")
    if not have_mvs:
        print("vp-mvs was not run (see above).")
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
