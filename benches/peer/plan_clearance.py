"""An independent clearance check of a plan: every waypoint of a vpctl
plan.json against every triangle of the binary PLY mesh it was planned on
(exact point-triangle distance in numpy, no code shared with the planner).

    python benches/peer/plan_clearance.py PLAN.json MESH.ply [SAFETY_M]

Prints each waypoint's distance to the mesh ("more than 20 m" where no
triangle's bounding box comes within 20 m) and exits 1 when one is closer
than SAFETY_M (default 5). Used on the Brighton plans (README recipe), whose
meshes have millions of faces: a box test first, exact distances on what
is near. Needs numpy.
"""
import json
import sys

import numpy as np

def read_ply(path):
    with open(path, 'rb') as f:
        nv = nf = 0
        while True:
            line = f.readline().decode().strip()
            if line.startswith('element vertex'): nv = int(line.split()[-1])
            if line.startswith('element face'): nf = int(line.split()[-1])
            if line == 'end_header': break
        v = np.frombuffer(f.read(nv * 12), dtype='<f4').reshape(nv, 3).astype(np.float64)
        raw = np.frombuffer(f.read(nf * 13), dtype=np.dtype([('n', 'u1'), ('i', '<i4', 3)]))
        assert (raw['n'] == 3).all()
        return v, raw['i']

def seg_dist(p, a, b):
    ab = b - a
    t = np.clip(np.einsum('ij,ij->i', p - a, ab) / np.maximum(np.einsum('ij,ij->i', ab, ab), 1e-30), 0, 1)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)

def tri_dist(p, a, b, c):
    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n, axis=1)
    ok = nn > 1e-12
    un = n / np.maximum(nn, 1e-30)[:, None]
    d_plane = np.einsum('ij,ij->i', p - a, un)
    q = p - d_plane[:, None] * un
    s1 = np.einsum('ij,ij->i', np.cross(b - a, q - a), n)
    s2 = np.einsum('ij,ij->i', np.cross(c - b, q - b), n)
    s3 = np.einsum('ij,ij->i', np.cross(a - c, q - c), n)
    inside = ok & (((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0)))
    d = np.minimum(np.minimum(seg_dist(p, a, b), seg_dist(p, b, c)), seg_dist(p, c, a))
    return np.where(inside, np.abs(d_plane), d)

v, f = read_ply(sys.argv[2])
plan = json.load(open(sys.argv[1]))
a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
lo = np.minimum(np.minimum(a, b), c); hi = np.maximum(np.maximum(a, b), c)
worst = np.inf
for w in plan['waypoints']:
    p = np.array(w['position'], dtype=np.float64)
    box = np.linalg.norm(np.maximum(np.maximum(lo - p, p - hi), 0), axis=1)
    near = box < 20.0
    d = tri_dist(np.broadcast_to(p, (near.sum(), 3)), a[near], b[near], c[near]).min() if near.any() else np.inf
    worst = min(worst, d)
    dist = f"{d:.2f} m" if np.isfinite(d) else "more than 20 m"
    print(f"waypoint at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}): {dist} from the mesh")
safety = float(sys.argv[3]) if len(sys.argv) > 3 else 5.0
closest = f"{worst:.2f} m" if np.isfinite(worst) else "more than 20 m"
print(f"{len(v)} vertices, {len(f)} faces; closest waypoint {closest} from the mesh (safety distance {safety} m)")
sys.exit(0 if worst >= safety else 1)
