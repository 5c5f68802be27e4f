#!/usr/bin/env python3
"""CPU seconds per 1M rays of two builds of `raycast_peer`, alternating.

    python benches/peer/raycast_cpu_ab.py OLD_TARGET_DIR NEW_TARGET_DIR ROUNDS [REPEATS]

Each round runs both builds (the order alternates) on the site and rays of
raycast_vs_embree.py (200k faces, 1M rays, seed 7), one thread, closest hit
and occlusion (40 m). A build's figure is the rusage of the peer with
REPEATS repeats (default 6) minus that with 1 repeat, divided by
REPEATS - 1: the BVH build and file reading cancel. CPU time moves much
less than wall time when the cores are shared. Prints new/old per round
and the medians. Files go to /tmp/rq_cpu.
"""
import os, resource, subprocess, sys, numpy as np
old, new, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
R = int(sys.argv[4]) if len(sys.argv) > 4 else 6
tmp = "/tmp/rq_cpu"; os.makedirs(tmp, exist_ok=True)
site = f"{tmp}/site.ply"; rays = f"{tmp}/rays.bin"
if not os.path.exists(rays):
    subprocess.run([f"{old}/release/vpctl", "scene", "generate", "--seed", "1", "--faces", "200000", "--out", site], check=True, stdout=subprocess.DEVNULL)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raycast_vs_embree import read_ply_binary
    verts, faces = read_ply_binary(site)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    rng = np.random.default_rng(7); n = 1_000_000
    o = np.empty((n, 3)); o[:, 0] = rng.uniform(lo[0], hi[0], n); o[:, 1] = rng.uniform(lo[1], hi[1], n); o[:, 2] = hi[2] + rng.uniform(10, 50, n)
    t = np.empty((n, 3)); t[:, 0] = rng.uniform(lo[0], hi[0], n); t[:, 1] = rng.uniform(lo[1], hi[1], n); t[:, 2] = lo[2]
    d = t - o; d /= np.linalg.norm(d, axis=1, keepdims=True)
    np.hstack([o.astype(np.float32), d.astype(np.float32)]).astype("<f4").tofile(rays)
def cpu(dir, reps, mode):
    extra = ["occluded", "40"] if mode == "occ" else []
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([f"{dir}/release/examples/raycast_peer", site, rays, "1", str(reps), f"{tmp}/out.bin"] + extra, check=True, stdout=subprocess.DEVNULL)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
res = {(w, m): [] for w in ("old", "new") for m in ("closest", "occ")}
for r in range(rounds):
    order = [("old", old), ("new", new)] if r % 2 == 0 else [("new", new), ("old", old)]
    for m in ("closest", "occ"):
        for w, d in order:
            c = (cpu(d, R, m) - cpu(d, 1, m)) / (R - 1)
            res[(w, m)].append(c)
    load = open("/proc/loadavg").read().split()[0]
    print(f"round {r+1} load {load}: " + ", ".join(f"{w} {m} {res[(w,m)][-1]:.3f}" for m in ("closest","occ") for w in ("old","new")), flush=True)
med = lambda x: float(np.median(x))
for m in ("closest", "occ"):
    ratios = [n / o for o, n in zip(res[("old", m)], res[("new", m)])]
    print(f"{m}: old median {med(res[('old',m)]):.3f} s, new median {med(res[('new',m)]):.3f} s per 1M rays; new/old per round: " + " ".join(f"{x:.2f}" for x in ratios) + f"; median {med(ratios):.2f}")
