"""``vpctl-dask``: the offline pipeline of vpctl on a Dask cluster.

    vpctl-dask train --workspace SITE --out model.vpforest [--scheduler tcp://host:8786]

runs triplet MVS, label generation and forest training of a site directory
(see :func:`vpctl.distributed.site_layout`) with Dask's progress bars.
Without ``--scheduler`` a LocalCluster sized to the machine does the work.
Exit codes as ``vpctl``: 0 done, 1 a failure, 2 bad input.
"""

from __future__ import annotations

import argparse
import sys


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vpctl-dask", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser(
        "train",
        help="MVS of every triplet, labels, forest: a site directory to a model file",
        description="Site directory: dense/ (aligned COLMAP dense workspace), triplets.txt, "
        "optionally mesh.ply and mvs.toml, labels.toml, forest.toml. Writes depth/, labels/ "
        "and the model file.",
    )
    t.add_argument("--workspace", required=True, help="the site directory")
    t.add_argument("--out", required=True, help="model file to write")
    t.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 "
                   "(default: a LocalCluster on this machine)")
    t.add_argument("--levels", default="1,2,3", help="pyramid levels of the triplet MVS")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--max-per-label-image", type=int)
    t.add_argument("--frame-unchecked", action="store_true",
                   help="skip the frame check of the model (as vpctl labelgen run)")
    t.add_argument("--force", action="store_true", help="overwrite existing outputs")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        from vpctl import distributed
    except ImportError as e:
        print(f"vpctl-dask: {e}", file=sys.stderr)
        return 2
    try:
        levels = [int(x) for x in args.levels.split(",") if x.strip()]
    except ValueError:
        print(f"vpctl-dask: --levels {args.levels!r}: expected e.g. 1,2,3", file=sys.stderr)
        return 2
    try:
        forest = distributed.train_site(
            args.workspace, args.out, client=args.scheduler, levels=levels, seed=args.seed,
            max_per_label_image=args.max_per_label_image, frame_unchecked=args.frame_unchecked,
            force=args.force, show_progress=True,
        )
    except (ValueError, FileNotFoundError, FileExistsError) as e:
        print(f"vpctl-dask: error: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 - every failure becomes exit 1 with its message
        print(f"vpctl-dask: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    s = forest.summary
    print(f"trees: {forest.n_trees}, nodes {s['n_nodes']}, leaves {s['n_leaves']}")
    print(f"trained on: {s['n_positive']} positive, {s['n_negative']} negative samples")
    print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
