"""``vpctl-dask``: the offline pipeline of vpctl on a Dask cluster.

    vpctl-dask train --workspace SITE --out model.vpforest [--scheduler tcp://host:8786]

runs triplet MVS, label generation and forest training of a site directory
(see :func:`vpctl.distributed.site_layout`) with Dask's progress bars.
Paper-scale training in bounded memory goes through a patch store:

    vpctl-dask store --images IMAGES --labels LABELS --out STORE [--params forest.toml]
    vpctl-dask train --store STORE --out model.vpforest [--budget-mb 4096]

(the same model as training from IMAGES and LABELS with the same seed).
Without ``--scheduler`` a LocalCluster sized to the machine does the work.
Exit codes as ``vpctl``: 0 done, 1 a failure, 2 bad input.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


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
    src = t.add_mutually_exclusive_group(required=True)
    src.add_argument("--workspace", help="the site directory")
    src.add_argument("--store", help="a patch store (vpctl-dask store): forest training only, "
                     "each tree streaming the store chunk by chunk")
    t.add_argument("--out", required=True, help="model file to write")
    t.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 "
                   "(default: a LocalCluster on this machine)")
    t.add_argument("--levels", default="1,2,3", help="pyramid levels of the triplet MVS")
    t.add_argument("--seed", type=int, default=0,
                   help="with --workspace (a store trains with the seed it was written with)")
    t.add_argument("--max-per-label-image", type=int)
    t.add_argument("--frame-unchecked", action="store_true",
                   help="skip the frame check of the model (as vpctl labelgen run)")
    t.add_argument("--force", action="store_true", help="overwrite existing outputs")
    t.add_argument("--params", help="with --store: forest parameters (TOML, as forest.toml)")
    t.add_argument("--budget-mb", type=int, default=4096,
                   help="with --store: MiB of patches a tree task may hold (default 4096)")
    s = sub.add_parser(
        "store",
        help="write the samples training draws as a chunked patch store (one job, this machine)",
        description="Loads images and labels as vpctl train does and writes the drawn samples' "
        "27x27 Lab patches, labels and angles in chunks with a manifest.json.",
    )
    s.add_argument("--images", required=True)
    s.add_argument("--labels", required=True)
    s.add_argument("--out", required=True, help="store folder to write (atomically)")
    s.add_argument("--params", help="forest parameters (TOML, as forest.toml)")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--max-per-label-image", type=int)
    s.add_argument("--chunk-len", type=int, default=16384, help="patches per chunk file")
    s.add_argument("--force", action="store_true", help="replace an existing store")
    return p


def _store(args: argparse.Namespace, distributed: Any) -> int:
    from pathlib import Path

    def _params(path: str | None) -> dict | None:
        if path is None:
            return None
        if not Path(path).is_file():
            raise FileNotFoundError(f"--params {path}: no such file")
        return distributed._toml(Path(path))

    if args.command == "store":
        m = distributed.write_patch_store(
            args.images, args.labels, args.out, params=_params(args.params), seed=args.seed,
            max_per_label_image=args.max_per_label_image, chunk_len=args.chunk_len,
            force=args.force,
        )
        print(f"store: {m['n_samples']} samples ({m['n_positive']} positive, "
              f"{m['n_negative']} negative) in {len(m['chunks'])} chunks")
        print(f"written: {args.out}")
        print(f"next: vpctl-dask train --store {args.out} --out model.vpforest")
        return 0
    forest = distributed.train_forest_from_store(
        args.store, params=_params(args.params), client=args.scheduler, out=args.out,
        budget_mb=args.budget_mb, force=args.force, show_progress=True,
    )
    s = forest.summary
    print(f"trees: {forest.n_trees}, nodes {s['n_nodes']}, leaves {s['n_leaves']}")
    print(f"trained on: {s['n_positive']} positive, {s['n_negative']} negative samples")
    print(f"written: {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        from vpctl import distributed
    except ImportError as e:
        print(f"vpctl-dask: {e}", file=sys.stderr)
        return 2
    if args.command == "train" and args.store is not None and args.seed != 0:
        print("vpctl-dask: error: --seed is the store's (vpctl-dask store --seed); "
              "train --store takes none", file=sys.stderr)
        return 2
    if args.command == "store" or args.store is not None:
        try:
            return _store(args, distributed)
        except (ValueError, FileNotFoundError, FileExistsError, OSError) as e:
            print(f"vpctl-dask: error: {e}", file=sys.stderr)
            return 2
        except Exception as e:  # noqa: BLE001 - every failure becomes exit 1 with its message
            print(f"vpctl-dask: error: {type(e).__name__}: {e}", file=sys.stderr)
            return 1
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
