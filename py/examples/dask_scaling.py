"""Wall time and peak memory of vpctl.distributed with 1 and 2 workers.

    python py/examples/dask_scaling.py [--size 192] [--triplets 6] [--trees 8]

Builds a site directory (a rendered heightfield seen by `--triplets`
triplets of `--size`-pixel-wide cameras), then runs each stage (triplet MVS
at levels 1 and 2, labels, training) on a fresh LocalCluster of 1 and then 2
single-threaded workers (RAYON_NUM_THREADS=1 in each), and prints per stage
the wall time, the 1/2 ratio, the peak resident memory of each worker
process (ru_maxrss) and the work done (pixels, reconstructions, tree nodes),
from which README's extrapolation to the paper's scale is made. Every run
must give the same model bytes; the script checks it.
"""

import argparse
import math
import resource
import sys
import tempfile
import time
from pathlib import Path

import distributed

import vpctl
import vpctl.distributed as vd


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def stage(client, times, cpu, name, fn):
    """Runs fn, recording wall time and the CPU seconds all workers spent."""
    before = sum(client.run(cpu_seconds).values())
    t0 = time.perf_counter()
    result = fn()
    times[name] = time.perf_counter() - t0
    cpu[name] = sum(client.run(cpu_seconds).values()) - before
    return result


def make_site(root: Path, size: int, n_triplets: int) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
    from conftest import heightfield  # the tests' heightfield with a box

    mesh = heightfield(n=60, spacing=1.5)
    caster = vpctl.scene.RayCaster(mesh)
    k = (size, size * 3 // 4, 60.0)
    cams, triplets = [], []
    angles = [8.0, 15.0, 25.0, 35.0]
    for t in range(n_triplets):
        angle = angles[t % len(angles)]
        cx, cy = -10.0 + 10.0 * (t % 3), -10.0 + 10.0 * ((t // 3) % 3)
        r = 2.0 * 32.0 * math.tan(math.radians(0.5 * angle)) / math.sqrt(3.0)
        names = []
        for i in range(3):
            a = 0.4 * t + i * 2.0 * math.pi / 3.0
            c = [cx + r * math.cos(a), cy + r * math.sin(a), 32.0]
            name = f"img{t:02}{i}.png"
            cams.append((name, vpctl.scene.Camera.look_at(*k, c, [cx, cy, 0.0])))
            names.append(name)
        triplets.append({"bin": 0, "angle_deg": angle, "images": names})
    s = vd.site_layout(root)
    s["images"].mkdir(parents=True)
    for name, cam in cams:
        vpctl.scene.save_image(s["images"] / name, vpctl.sim.render(mesh, caster, cam)["rgb"])
    vpctl.labelgen.sparse_model(cams, caster, mesh.vertices[::3]).save(s["model"], format="text")
    mesh.save(s["mesh"])
    vpctl.labelgen.write_triplet_list(s["triplets"], triplets)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--triplets", type=int, default=6)
    ap.add_argument("--trees", type=int, default=8)
    ap.add_argument("--depth", type=int, default=12)
    ap.add_argument("--tests", type=int, default=1000)
    ap.add_argument("--probe", action="store_true",
                    help="also train one tree at the paper's node parameters (1 worker)")
    a = ap.parse_args()
    forest = dict(n_trees=a.trees, max_depth=a.depth, min_samples_split=20, n_tests=a.tests,
                  n_thresholds=50, n_node_samples=1000, balance_classes=False)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "site"
        make_site(root, a.size, a.triplets)
        s = vd.site_layout(root)
        models = {}
        for workers in (1, 2):
            with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                          dashboard_address=":0",
                                          env={"RAYON_NUM_THREADS": "1"}) as cluster, \
                    distributed.Client(cluster) as client:
                out = Path(tmp) / f"w{workers}"
                times, cpu = {}, {}
                stage(client, times, cpu, "mvs", lambda: vd.reconstruct_triplets(
                    s["dense"], s["triplets"], [1, 2], out / "depth", client=client))
                summary = stage(client, times, cpu, "labels", lambda: vd.generate_labels(
                    s["model"], s["triplets"], out / "depth", out / "labels", client=client,
                    mesh=s["mesh"], frame_unchecked=True))
                model = stage(client, times, cpu, "train", lambda: vd.train_forest(
                    s["images"], out / "labels", forest, seed=1, client=client))
                if a.probe and workers == 1:
                    paper = dict(n_trees=1, max_depth=20, min_samples_split=50, n_tests=5000,
                                 n_thresholds=100, n_node_samples=1000, balance_classes=False)
                    tree = stage(client, times, cpu, "paper_tree", lambda: vd.train_forest(
                        s["images"], out / "labels", paper, seed=1, client=client))
                    ps = tree.summary
                    print(f"  one tree at the paper's node parameters: {ps['n_nodes']} nodes, "
                          f"{ps['n_leaves']} leaves, depth {ps['max_depth_reached']}, "
                          f"{cpu['paper_tree']:.1f} CPU s")
                rss = client.run(peak_rss_mb)
                models[workers] = model.to_bytes()
                sm = model.summary
                print(f"workers={workers} " + " ".join(f"{k}={v:.1f}s" for k, v in times.items())
                      + f" total={sum(times.values()):.1f}s cpu: "
                      + " ".join(f"{k}={v:.1f}s" for k, v in cpu.items())
                      + " peak_rss_mb=" + ",".join(f"{v:.0f}" for v in sorted(rss.values())))
                print(f"  work: {3 * a.triplets} images of {a.size}x{a.size * 3 // 4}, "
                      f"{2 * a.triplets} reconstructions (levels 1,2), "
                      f"{summary['positive'] + summary['negative_voted'] + summary['negative_missing']} labels, "
                      f"{sm['n_positive'] + sm['n_negative']} training samples, {sm['n_nodes']} nodes "
                      f"in {a.trees} trees (depth {a.depth}, {a.tests} tests x 1000 node samples)")
                if workers == 1:
                    first = {k: v for k, v in times.items() if k != "paper_tree"}
        print("ratio 1 worker / 2 workers: " + " ".join(
            f"{k}={first[k] / times[k]:.2f}" for k in times)
              + f" total={sum(first.values()) / sum(times.values()):.2f}")
        assert models[1] == models[2], "model bytes differ between 1 and 2 workers"
        print("model bytes equal with 1 and 2 workers")


if __name__ == "__main__":
    main()
