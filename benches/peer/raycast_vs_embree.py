#!/usr/bin/env python3
"""Closest-hit and occlusion rays/s of vp-scene against Embree (embreex) on
the same procedural site and the same rays, in one script run, interleaved.

    .venv/bin/pip install embreex numpy
    cargo build --release -p vpctl --example raycast_peer -p vpctl-suite
    .venv/bin/python benches/peer/raycast_vs_embree.py [--faces 200000] [--rays 1000000]

Rays: from 10-50 m above the site towards random points of its footprint
(the distribution of benches/raycast.rs); occlusion segments are the first
40 m of each ray (as in that bench). Embree runs on one thread (embreex
traces ray by ray). Prints the median rays/s of each engine, the ratios,
and how often the two agree on the hit distance and on occlusion.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


def read_ply_binary(path):
    """Vertices and faces of a binary little-endian PLY written by vpctl."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = nf = 0
    vprops = []
    in_vertex = False
    for line in header:
        w = line.split()
        if w[:2] == ["element", "vertex"]:
            nv, in_vertex = int(w[2]), True
        elif w[:2] == ["element", "face"]:
            nf, in_vertex = int(w[2]), False
        elif w[0] == "property" and in_vertex:
            vprops.append(w[1])
    vtype = {"float": "<f4", "double": "<f8"}[vprops[0]]
    verts = np.frombuffer(data, dtype=vtype, count=nv * 3, offset=end).reshape(nv, 3)
    off = end + nv * 3 * np.dtype(vtype).itemsize
    has_material = b"property uchar material" in data[:end]
    rec = np.dtype([("n", "u1"), ("i", "<i4", 3)] + ([("m", "u1")] if has_material else []))
    faces = np.frombuffer(data, dtype=rec, count=nf, offset=off)
    assert (faces["n"] == 3).all()
    return verts.astype(np.float64), faces["i"].astype(np.int32)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--faces", type=int, default=200_000)
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()

    import embreex.mesh_construction as mc
    import embreex.rtcore_scene as rs

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target"))
    vpctl = os.path.join(target, "release", "vpctl")
    peer = os.path.join(target, "release", "examples", "raycast_peer")
    tmp = tempfile.mkdtemp()
    site = os.path.join(tmp, "site.ply")
    subprocess.run([vpctl, "scene", "generate", "--seed", "1", "--faces", str(args.faces), "--out", site],
                   check=True, stdout=subprocess.DEVNULL)
    verts, faces = read_ply_binary(site)
    lo, hi = verts.min(axis=0), verts.max(axis=0)

    rng = np.random.default_rng(args.seed)
    n = args.rays
    o = np.empty((n, 3))
    o[:, 0] = rng.uniform(lo[0], hi[0], n)
    o[:, 1] = rng.uniform(lo[1], hi[1], n)
    o[:, 2] = hi[2] + rng.uniform(10, 50, n)
    t = np.empty((n, 3))
    t[:, 0] = rng.uniform(lo[0], hi[0], n)
    t[:, 1] = rng.uniform(lo[1], hi[1], n)
    t[:, 2] = lo[2]
    d = t - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    rays_file = os.path.join(tmp, "rays.bin")
    np.hstack([o32, d32]).astype("<f4").tofile(rays_file)

    scene = rs.EmbreeScene()
    mc.TriangleMesh(scene, verts.astype(np.float32), faces)
    scene.run(o32[:1000], d32[:1000], output=1)  # warm up (builds the BVH)

    seg_len = 40.0
    # vp-scene shortens a segment by this relative tolerance at its far end.
    seg_dists = np.full(n, seg_len * (1.0 - 1e-5), dtype=np.float32)
    embree, ours1, ours2 = [], [], []
    embree_occ, ours1_occ, ours2_occ = [], [], []
    t_ours = os.path.join(tmp, "t.bin")
    occ_ours = os.path.join(tmp, "occ.bin")
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        res = scene.run(o32, d32, output=1)
        embree.append(n / (time.perf_counter() - t0))
        for threads, sink in ((1, ours1), (2, ours2)):
            out = subprocess.run([peer, site, rays_file, str(threads), "1", t_ours],
                                 check=True, capture_output=True, text=True).stdout
            sink.append(float(out.split("=")[1]))
        t0 = time.perf_counter()
        occ = scene.run(o32, d32, dists=seg_dists, query="OCCLUDED")
        embree_occ.append(n / (time.perf_counter() - t0))
        for threads, sink in ((1, ours1_occ), (2, ours2_occ)):
            out = subprocess.run([peer, site, rays_file, str(threads), "1", occ_ours,
                                  "occluded", str(seg_len)],
                                 check=True, capture_output=True, text=True).stdout
            sink.append(float(out.split("=")[1]))

    t_embree = np.where(res["geomID"] >= 0, res["tfar"], np.inf)
    t_vp = np.fromfile(t_ours, dtype="<f4")
    both = np.isfinite(t_embree) & np.isfinite(t_vp)
    agree = np.isclose(t_embree[both], t_vp[both], rtol=1e-4, atol=1e-4).mean()
    hit_agree = (np.isfinite(t_embree) == np.isfinite(t_vp)).mean()

    occ_embree = occ >= 0
    occ_vp = np.fromfile(occ_ours, dtype="u1").astype(bool)
    occ_agree = (occ_embree == occ_vp).mean()

    med = statistics.median
    print(f"mesh: {len(faces)} faces; rays: {n}; repeats: {args.repeats} (interleaved)")
    for name, e, o1, o2 in (("closest hit", embree, ours1, ours2),
                            (f"occlusion ({seg_len:g} m)", embree_occ, ours1_occ, ours2_occ)):
        print(f"{name}:")
        print(f"  embree 1 thread (embreex, from Python): {med(e) / 1e6:.2f} M rays/s")
        print(f"  vp-scene 1 thread:                      {med(o1) / 1e6:.2f} M rays/s")
        print(f"  vp-scene 2 threads:                     {med(o2) / 1e6:.2f} M rays/s")
        print(f"  ratio vp-scene(1 thread) / embree:      {med(o1) / med(e):.2f}")
        print(f"  ratio vp-scene(2 threads) / embree:     {med(o2) / med(e):.2f}")
        print(f"  per-repeat ratios (1 thread):           "
              + " ".join(f"{a / b:.2f}" for a, b in zip(o1, e)))
    print(f"hit/miss agreement: {hit_agree:.5f}; distance agreement where both hit: {agree:.5f}")
    print(f"occlusion agreement: {occ_agree:.5f}")


if __name__ == "__main__":
    sys.exit(main())
