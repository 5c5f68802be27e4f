"""A notebook-style tour of vpctl from Python (plain .py: run it, or paste
the cells into Jupyter). It generates a procedural site, renders a few
images, trains a tiny confidence forest on labels from a virtual MVS,
plans the next camera triplets with the predicted confidence, exports the
mission, and plots the result with matplotlib when it is installed.

    python py/examples/notebook.py [--out DIR]
"""

# %% Setup
import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

import vpctl

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
args = parser.parse_args()
out = args.out or Path(tempfile.mkdtemp(prefix="vpctl_notebook_"))
out.mkdir(parents=True, exist_ok=True)

# %% A procedural site: terrain, a rock, trees, grass, markers.
site = vpctl.scene.generate_site(seed=2, faces=20_000)
mesh = site.mesh
caster = vpctl.scene.RayCaster(mesh)
print("site:", site.summary()["faces_per_material"])
lo, hi = site.rock_bounds
centre = (lo + hi) / 2

# %% An initial grid flight over the rock (the paper's first step), looking
# straight down. (An oblique grid pictures little of the space around its own
# positions, and with unknown_space = "occupied" the leg out of the last one
# is then refused: docs/campaign-findings.md.)
camera = {"width": 320, "height": 240, "focal_px": 300.0}
fv = site.flight_volume.tolist()
footprint = [centre[0] - 20, centre[1] - 20, lo[2], centre[0] + 20, centre[1] + 20, hi[2]]
initial = vpctl.planner.plan_grid(mesh, roi=footprint, height=30.0, overlap=0.6, pitch=-90.0,
                                  initial=True, config={"camera": camera, "flight_volume": fv})
cams = vpctl.planner.plan_cameras(initial, config={"camera": camera})
print("initial flight:", len(cams), "images")

# %% Render the images and reconstruct triplets with the virtual MVS.
mvs = vpctl.sim.VirtualMvs("sure")
images, labels, angles = [], [], []
for i, cam in enumerate(cams[: 3 * (len(cams) // 3)]):
    images.append(vpctl.sim.render(mesh, caster, cam)["rgb"])
for t in range(len(images) // 3):
    trip = cams[3 * t: 3 * t + 3]
    depths = mvs.reconstruct(mesh, caster, trip, seed=t)
    for cam, depth in zip(trip, depths):
        truth, _ = caster.render_depth(cam)
        # Training labels straight from the simulator's truth (labelgen does
        # this without ground truth from many triplets; see vpctl.labelgen).
        ok = (depth > 0) & (np.abs(depth - truth) < 0.02 * np.maximum(truth, 1e-6))
        lab = np.where(truth > 0, np.where(ok, 1, 2), 0).astype(np.uint8)
        ang = np.full(lab.shape, np.nan, dtype=np.float32)
        ang[lab > 0] = 10.0
        labels.append(lab)
        angles.append(ang)

# %% Train a tiny forest and predict confidence images.
tiny = {"n_trees": 3, "max_depth": 8, "min_samples_split": 10, "n_tests": 60,
        "n_thresholds": 10, "n_node_samples": 200, "samples_per_class": 4000}
forest = vpctl.forest.train(images, labels, angles, params=tiny, seed=1, max_per_label_image=4000)
forest.save(out / "tiny.vpforest", force=True)
conf = [forest.predict(img, step=8) for img in images]
conf += [vpctl.forest.ConfidenceImage.constant(1.0)] * (len(cams) - len(conf))
print("forest:", forest.n_trees, "trees; confidence grid", conf[0].values.shape)

# %% Plan the next triplets with the predicted confidence.
# The simulated cameras are exact, as an RTK drone's would be; a consumer
# drone's standard GNSS (the default) adds about 12.8 m to the clearance.
cfg = {"n_triangles": 300, "n_surrogates": 600, "n_selected": 60, "n_triplets": 2,
       "camera": camera, "flight_volume": fv, "safety": {"gnss": "rtk"}}
# The site's origin lies on its ground, where the vehicle takes off: the home.
result = vpctl.planner.plan(mesh, cams, confidence=conf, config=cfg, roi=[*lo, *hi],
                            origin=(46.0, 10.3, 400.0), home=(46.0, 10.3, 400.0))
plan = result.plan
plan.save(out / "plan.json", force=True)
for it in result.iterations:
    print(f"triplet {it['iteration']}: mean f {it['f_before']:.3f} -> {it['f_after']:.3f}")
for t, why in zip(result.dropped_triplets, result.dropped_reasons):
    print(f"dropped triplet {t}: {why}")

# %% Export the mission for QGroundControl, and fly it on the simulated vehicle.
vpctl.mission.export(plan, out=out / "mission.plan", force=True)
with vpctl.mission.SimulatedVehicle() as vehicle:
    report = vpctl.mission.upload(plan, vehicle.url)
    print("uploaded", report["items"], "items; verified:", report["verified"])

# %% Plot: top view of the mesh, the sampled fulfillment and the planned path.
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib not installed: no plot")
else:
    fig, ax = plt.subplots(figsize=(7, 7))
    c = mesh.face_centroids()
    ax.scatter(c[::7, 0], c[::7, 1], s=0.2, c=c[::7, 2], cmap="terrain")
    s = result.sampled
    sc = ax.scatter(s["centroid"][:, 0], s["centroid"][:, 1], s=6, c=s["f"], cmap="RdYlGn", vmin=0, vmax=1)
    p = plan.positions
    ax.plot(p[:, 0], p[:, 1], "k.-", lw=0.8)
    ip = initial.positions
    ax.plot(ip[:, 0], ip[:, 1], "b^", ms=4)
    fig.colorbar(sc, label="f(t)")
    ax.set_aspect("equal")
    ax.set_title("vpctl: initial flight (blue), planned triplets (black)")
    fig.savefig(out / "plan.png", dpi=100)
    print("plot:", out / "plan.png")
print("outputs in", out)
