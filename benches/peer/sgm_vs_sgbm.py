#!/usr/bin/env python3
"""Gate G0 (issue 35): vp-mvs's semi-global matcher against OpenCV's
StereoSGBM on the same pairs, in one run: the share of ground-truth pixels
within 2 px, and the time ratio.

    python3 -m venv .venv && .venv/bin/pip install -r benches/peer/requirements-mvs.txt
    cargo build --release -p vpctl
    .venv/bin/python benches/peer/sgm_vs_sgbm.py [--pairs motorcycle,aloe,rendered] [--repeat 3]

The pairs, the ground truth, the score and StereoSGBM's parameters are those
of benches/peer/mvs_vs_sgbm.py (imported, not copied): Middlebury 2014
Motorcycle (quarter size, from scikit-image), Middlebury 2006 Aloe (Debian's
opencv-doc, skipped when absent) and rendered rectified pairs of a procedural
site (`vpctl sim render`, exact depth), here at several baselines
(--baselines, metres) so that the angle at the scene centre (printed) varies.

StereoSGBM, "default-style" parameters (OpenCV's documented formula):
mode SGBM_3WAY, blockSize 5, P1 = 8 * 3 * 5^2 = 600, P2 = 32 * 3 * 5^2 = 2400,
disp12MaxDiff 1, preFilterCap 63, uniquenessRatio 10, speckleWindowSize
100, speckleRange 2; minDisparity/numDisparities from the ground truth's
range +- --margin px (rounded up to 16).

vp-mvs: `vpctl mvs run --algorithm sgm --workspace WS --depth-range MIN,MAX`
on a COLMAP workspace with the left image as the only reference (its
patch-match.cfg names right.png as left.png's source, and nothing for
right.png), so both methods compute one disparity map of the left image
with a left-right check. The score is on vp-mvs's photometric map (the
pair's SGM output; the geometric filter needs a second reference). The
depth interval is the same disparity interval as SGBM's.

Time: SGBM is the `compute()` call; vp-mvs is the whole `vpctl` process
(start-up, reading the workspace and images, rectification, matching,
writing the maps), the best of --repeat runs for both. The ratio is
vp-mvs time / SGBM time (<= 1: vp-mvs at least as fast).
"""
import argparse
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mvs_vs_sgbm as base  # noqa: E402  (the shared pairs and score)


def run_sgm(pair, lo, hi, vpctl, ws, repeat):
    """vp-mvs sgm on the left image against the right one: (disparity, best
    wall time, best CPU time, command)."""
    if os.path.exists(ws):
        shutil.rmtree(ws)
    base.write_workspace(pair, ws)
    with open(os.path.join(ws, "stereo", "patch-match.cfg"), "w") as fh:
        fh.write("left.png\nright.png\n")
    zmin = pair.f * pair.baseline / (hi + pair.doffs)
    zmax = pair.f * pair.baseline / max(lo + pair.doffs, 1e-3)
    cmd = [vpctl, "mvs", "run", "--algorithm", "sgm", "--workspace", ws,
           "--depth-range", f"{zmin:.6g},{zmax:.6g}", "--force"]
    best, best_cpu = math.inf, math.inf
    for _ in range(repeat):
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        best = min(best, time.perf_counter() - t0)
        ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        best_cpu = min(best_cpu, ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime)
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed (exit {r.returncode}):\n{r.stderr[-2000:]}")
    p = os.path.join(ws, "stereo", "depth_maps", "left.png.photometric.bin")
    z = base.read_colmap_depth(p)[0].astype(np.float64)
    d = np.full(z.shape, np.nan)
    ok = (z > 0) & np.isfinite(z)
    d[ok] = pair.f * pair.baseline / z[ok] - pair.doffs
    return d, best, best_cpu, " ".join(cmd[1:])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", default="motorcycle,aloe,rendered")
    ap.add_argument("--aloe-scale", type=float, default=0.5)
    ap.add_argument("--vpctl", default=None, help="vpctl binary (default $CARGO_TARGET_DIR/release/vpctl)")
    ap.add_argument("--margin", type=int, default=4)
    ap.add_argument("--sgbm-mode", choices=["3way", "hh", "sgbm"], default="3way")
    ap.add_argument("--block-size", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--faces", type=int, default=200_000)
    ap.add_argument("--render-size", type=lambda s: tuple(int(v) for v in s.split("x")), default=(640, 480))
    ap.add_argument("--render-from", default="-30,-25,30")
    ap.add_argument("--render-at", default="0,0,0")
    ap.add_argument("--hfov", type=float, default=60.0)
    ap.add_argument("--baselines", default="1.5,3,6", help="rendered pairs' baselines, metres")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per method (best kept)")
    ap.add_argument("--keep", default=None)
    args = ap.parse_args()

    import cv2

    vpctl = base.vpctl_path(args.vpctl)
    if not os.path.exists(vpctl):
        sys.exit(f"{vpctl} does not exist: cargo build --release -p vpctl (or pass --vpctl)")
    tmp = args.keep or tempfile.mkdtemp(prefix="sgm_vs_sgbm_")
    os.makedirs(tmp, exist_ok=True)
    print(f"opencv {cv2.__version__} ({cv2.getNumThreads()} threads), numpy {np.__version__}; vpctl {vpctl}")

    pairs = []
    for name in [p.strip() for p in args.pairs.split(",") if p.strip()]:
        if name == "motorcycle":
            pairs.append(base.load_motorcycle())
        elif name == "aloe":
            try:
                pairs.append(base.load_aloe(args.aloe_scale))
            except FileNotFoundError as e:
                print(f"aloe pair SKIPPED: {e}")
        elif name == "rendered":
            dist = np.linalg.norm(np.array([float(v) for v in args.render_from.split(",")])
                                  - np.array([float(v) for v in args.render_at.split(",")]))
            for b in [float(v) for v in args.baselines.split(",")]:
                args.baseline = b
                sub = os.path.join(tmp, f"render_{b}")
                os.makedirs(sub, exist_ok=True)
                pair = base.render_pair(vpctl, sub, args)
                angle = math.degrees(2 * math.atan(0.5 * b / dist))
                pair.name = f"rendered {angle:.1f}deg"
                pairs.append(pair)
        else:
            sys.exit(f"unknown pair {name!r} (motorcycle, aloe, rendered)")

    rows = []
    for pair in pairs:
        h, w = pair.gt.shape
        lo, hi = base.search_range(pair, args.margin)
        print(f"\n== {pair.name}: {w}x{h}, {pair.note}")
        print(f"   disparity search [{lo}, {hi}] px (GT range +- {args.margin} px)")
        t_sg, c_sg = math.inf, math.inf
        for _ in range(args.repeat):
            c0 = time.process_time()
            sg, t, params = base.run_sgbm(pair, lo, hi, args)
            # CPU of all threads; includes the two colour conversions.
            c_sg = min(c_sg, time.process_time() - c0)
            t_sg = min(t_sg, t)
        print(f"   SGBM: {params}  [best {t_sg:.3f} s wall, {c_sg:.3f} s CPU, of {args.repeat}]")
        ws = os.path.join(tmp, f"ws_{pair.name.replace(' ', '_')}")
        vp, t_vp, c_vp, cmd = run_sgm(pair, lo, hi, vpctl, ws, args.repeat)
        print(f"   vp-mvs: vpctl {cmd}  [best {t_vp:.3f} s wall, {c_vp:.3f} s CPU, of {args.repeat}; whole process]")
        masks = [("all", None)] + ([("nonocc", pair.nonocc)] if pair.nonocc is not None else [])
        for mname, m in masks:
            s, v = base.score(pair, sg, m), base.score(pair, vp, m)
            print(f"   [{mname}, {s['n']} GT px] share within 2 px:")
            print(f"     StereoSGBM   {base.fmt(s)}")
            print(f"     vp-mvs sgm   {base.fmt(v)}")
            rows.append((pair.name, mname, s["within2"], v["within2"], t_sg, t_vp, c_sg, c_vp))

    print("\nsummary: share of GT pixels within 2 px (points); wall and CPU seconds, ratio vp-mvs / SGBM")
    print(f"  {'pair':<19} {'pixels':<7} {'SGBM':>7} {'vp-sgm':>7} {'diff':>6}  "
          f"{'wall SGBM':>9} {'wall vp':>8} {'ratio':>6}  {'CPU SGBM':>8} {'CPU vp':>7} {'ratio':>6}")
    for name, mname, s, v, ts, tv, cs, cv in rows:
        print(f"  {name:<19} {mname:<7} {100 * s:6.1f}% {100 * v:6.1f}% {100 * (v - s):+6.1f}  "
              f"{ts:9.3f} {tv:8.3f} {tv / ts:6.2f}  {cs:8.3f} {cv:7.3f} {cv / cs:6.2f}")
    within = all(abs(r[3] - r[2]) <= 0.10 for r in rows)
    faster = all(r[5] <= r[4] for r in rows)
    print(f"G0 accuracy (within +-10 points on every row): {'holds' if within else 'does NOT hold'}")
    print(f"G0 speed (vp-mvs at least as fast on every pair): {'holds' if faster else 'does NOT hold'}")
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
