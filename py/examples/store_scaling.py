"""Wall time and peak memory per worker of forest training from a patch
store, with 1 and 2 workers.

    python py/examples/store_scaling.py STORE [--trees 2] [--depth 20] [--budget-mb 4096]

STORE: a patch store at the paper's counts, e.g. from
``store_paper write STORE`` (crates/forest/examples/store_paper.rs: 4 M
patches per class of synthetic textures, 17.5 GB). Trains `--trees` trees of
the paper's configuration (5000 tests, 100 thresholds, 1000 samples per
node, depth `--depth`) on a fresh LocalCluster of 1 and then 2
single-threaded workers (RAYON_NUM_THREADS=1 each), and prints the wall
time, the CPU time of the workers and each worker process's peak resident
memory (ru_maxrss). Both runs must give the same model bytes; the script
checks it.
"""

import argparse
import resource
import time

import distributed

import vpctl.distributed as vd


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("store")
    ap.add_argument("--trees", type=int, default=2)
    ap.add_argument("--depth", type=int, default=20)
    ap.add_argument("--budget-mb", type=int, default=4096)
    ap.add_argument("--workers", default="1,2")
    a = ap.parse_args()
    params = dict(n_trees=a.trees, max_depth=a.depth, min_samples_split=50, n_tests=5000,
                  n_thresholds=100, n_node_samples=1000, samples_per_class=4_000_000,
                  balance_classes=True)
    models = {}
    for workers in [int(w) for w in a.workers.split(",")]:
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=":0", memory_limit=0,
                                      env={"RAYON_NUM_THREADS": "1"}) as cluster, \
                distributed.Client(cluster) as client:
            before = sum(client.run(cpu_seconds).values())
            t0 = time.perf_counter()
            model = vd.train_forest_from_store(a.store, params, client=client,
                                               budget_mb=a.budget_mb)
            wall = time.perf_counter() - t0
            cpu = sum(client.run(cpu_seconds).values()) - before
            rss = sorted(client.run(peak_rss_mb).values())
            models[workers] = model.to_bytes()
            s = model.summary
            print(f"{workers} worker(s): {a.trees} trees in {wall:.1f} s wall, {cpu:.1f} CPU s; "
                  f"{s['n_nodes']} nodes; peak RSS per worker "
                  + ", ".join(f"{r:.0f} MB" for r in rss), flush=True)
    if len(set(models.values())) > 1:
        raise SystemExit("the models differ between worker counts")
    print("same model bytes with every worker count")


if __name__ == "__main__":
    main()
