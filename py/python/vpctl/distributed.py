"""The offline pipeline on Dask: MVS of every triplet, label generation and
forest training, on a LocalCluster or a real cluster, with the results of
one machine.

Install with the extra: ``pip install './py[dask]'``. Every function takes
``client=``: ``None`` starts a :class:`distributed.LocalCluster` sized to
the machine (one single-threaded worker process per core) and closes it at
the end; a :class:`distributed.Client` is used as it is; a string is a
scheduler address (``tcp://host:8786``) to connect to (and disconnect from).

- :func:`reconstruct_triplets`: one task per (triplet, pyramid level),
  vp-mvs on the triplet's three images, written into the layout ``vpctl
  labelgen run`` reads (``<out>/<triplet id>/level<L>/``).
- :func:`generate_labels`: consistency voting in chunks of reconstructions,
  two waves: stage 1 (support) per chunk, then stages 2-3 per chunk, which
  read the support of the chunk's references. What is shared: every task
  loads every depth map (each reconstruction may be a reference of any
  other; once per worker process), and stage 2 cannot start before the
  stage-1 results of the references exist (they stay in the workers'
  memory as Dask results and travel only to the chunks that need them).
- :func:`train_forest`: one task per tree (the tree's seed is derived from
  the forest seed and its index), assembled into the model on the client:
  the same bytes as ``vpctl train`` with the same data, parameters and seed.
- :func:`write_patch_store` / :func:`train_forest_from_store`: the drawn
  samples written once as a chunked patch store on shared storage, then one
  task per tree streaming it chunk by chunk in bounded memory (a budget of
  patches plus one chunk, whatever the number of samples): the same bytes
  as :func:`train_forest` on the data the store was written from.
- :func:`predict`: confidence images of many images, in chunks.

Large inputs travel as paths on storage every worker sees (the workspace,
depth maps, images, label files); each worker process loads a data set
once and keeps it for later tasks. Outputs are written atomically: a task
writes into a private staging folder under the output and renames each
file into place, so a worker killed mid-task leaves no partial file in the
output, and Dask's rerun of the task writes the same bytes. The staging
folder (``.vpctl-partial``) is removed when the run ends.

Workers need the same vpctl as the client: each run first asks every worker
to import it and stops with an error naming the workers that cannot.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import time
import uuid
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Optional, Sequence, Union

try:
    import distributed
    from distributed import Client, LocalCluster
except ImportError:  # pragma: no cover - depends on the environment
    # The failed import shows as the context; no `as e`, whose name mypy
    # (and stubtest) would take for a module attribute.
    raise ImportError(
        "vpctl.distributed needs dask and distributed: pip install 'vpctl[dask]'"
    )

import vpctl
from vpctl._native import distributed as _native

__all__ = [
    "generate_labels",
    "predict",
    "reconstruct_triplets",
    "train_forest",
    "train_forest_from_store",
    "write_patch_store",
    "site_layout",
    "train_site",
]

PathLike = Union[str, "os.PathLike[str]"]
ClientLike = Union[None, str, Client]

#: How long connecting to a scheduler address may take, seconds.
CONNECT_TIMEOUT = 10.0
#: Staging folder of the tasks' outputs, under each output folder.
STAGING = ".vpctl-partial"


# --------------------------------------------------------------------------
# Clients and workers


@contextlib.contextmanager
def _client(client: ClientLike) -> Iterator[Client]:
    """The client to run on (see the module docs), checked: every worker
    imports the client's vpctl."""
    timeout = CONNECT_TIMEOUT
    if client is None:
        n = os.cpu_count() or 1
        # One single-threaded worker process per core, and a single-threaded
        # rayon pool in each: the tasks are the parallelism.
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            env={"RAYON_NUM_THREADS": "1"},
        )
        c = Client(cluster)
        try:
            _check_workers(c)
            yield c
        finally:
            c.close()
            cluster.close()
    elif isinstance(client, str):
        try:
            c = Client(client, timeout=timeout)
        except (OSError, TimeoutError) as e:
            raise ConnectionError(
                f"cannot reach the Dask scheduler at {client} within {timeout:g} s: {e}"
            ) from e
        try:
            _check_workers(c)
            yield c
        finally:
            c.close()
    else:
        _check_workers(client)
        yield client


# The probe travels by value (its module is not importable on the worker),
# so it runs even where vpctl is missing and can say so.
_PROBE = """
def probe():
    try:
        import vpctl._native as native
    except Exception as e:
        return "missing: " + type(e).__name__ + ": " + str(e)
    return native.__version__
"""


def _probe() -> Callable[[], str]:
    ns: dict[str, Any] = {"__name__": "__vpctl_probe__"}
    exec(_PROBE, ns)  # noqa: S102 - a fixed string
    return ns["probe"]


def _check_workers(client: Client) -> None:
    """Raises if the cluster has no worker (after CONNECT_TIMEOUT seconds)
    or a worker cannot import this client's vpctl."""
    wait_for = CONNECT_TIMEOUT
    deadline = time.monotonic() + wait_for
    while not client.scheduler_info(n_workers=-1).get("workers"):
        if time.monotonic() > deadline:
            raise RuntimeError(
                f"the Dask cluster at {client.scheduler.address} has no worker after "
                f"{wait_for:g} s: start one with `dask worker {client.scheduler.address}`"
            )
        time.sleep(0.1)
    versions = client.run(_probe())
    bad = {w: v for w, v in versions.items() if v != vpctl.__version__}
    if bad:
        lines = "; ".join(
            f"{w}: {v if v.startswith('missing') else 'vpctl ' + v}" for w, v in sorted(bad.items())
        )
        raise RuntimeError(
            f"Dask workers without the vpctl package {vpctl.__version__} (the client's): {lines}. "
            "Install it on every worker machine: pip install 'vpctl[dask]'"
        )


def _gather(client: Client, futures: list, show_progress: bool) -> list:
    if show_progress:
        distributed.progress(futures)
        print()
    return client.gather(futures)


# --------------------------------------------------------------------------
# Worker-side caches: a data set is loaded once per worker process.

_CACHE: dict[tuple, Any] = {}


def _stamp(*paths: Path) -> str:
    """Sizes and modification times of every file under `paths`: a cached
    data set is reloaded when its files change."""
    h = hashlib.sha256()
    for root in paths:
        root = Path(root)
        files = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.is_file())
        for p in files:
            st = p.stat()
            h.update(f"{p}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def _cached(key: tuple, load):
    if key not in _CACHE:
        # One data set per kind at a time: bounds a long-lived worker's memory.
        for k in [k for k in _CACHE if k[0] == key[0]]:
            del _CACHE[k]
        _CACHE[key] = load()
    return _CACHE[key]


# --------------------------------------------------------------------------
# Atomic outputs


def _staging(out: Path) -> Path:
    d = out / STAGING / uuid.uuid4().hex
    d.mkdir(parents=True)
    return d


def _move_into(staging: Path, out: Path) -> list[Path]:
    """Renames every file under `staging` to the same place under `out`
    (each rename atomic), then removes `staging`."""
    moved = []
    for p in sorted(staging.rglob("*")):
        if p.is_file():
            dest = out / p.relative_to(staging)
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(p, dest)
            moved.append(dest)
    shutil.rmtree(staging, ignore_errors=True)
    return moved


def _remove_staging(out: Path) -> None:
    shutil.rmtree(out / STAGING, ignore_errors=True)


def _missing(paths: Sequence[Path], what: str) -> None:
    gone = [str(p) for p in paths if not Path(p).exists()]
    if gone:
        more = f" (and {len(gone) - 10} more)" if len(gone) > 10 else ""
        raise FileNotFoundError(f"{what} not found: {', '.join(gone[:10])}{more}")


def _refuse_existing(paths: Sequence[Path], force: bool) -> None:
    if force:
        return
    there = [str(p) for p in paths if Path(p).exists()]
    if there:
        raise FileExistsError(
            f"would overwrite {', '.join(there[:5])}"
            + (f" (and {len(there) - 5} more)" if len(there) > 5 else "")
            + "; pass force=True"
        )


# --------------------------------------------------------------------------
# MVS


def _mvs_task(workspace: str, images: list, level: int, out: str, rel: str,
              params: Optional[dict], depth_range) -> list:
    out_p = Path(out)
    staging = _staging(out_p)
    shares = _native.mvs_image_set(workspace, images, level, str(staging / rel), params, depth_range)
    _move_into(staging, out_p)
    return shares


def reconstruct_triplets(
    workspace: PathLike,
    triplets: Union[PathLike, Sequence[Mapping[str, Any]]],
    levels: Sequence[int],
    out: PathLike,
    client: ClientLike = None,
    params: Optional[Mapping[str, Any]] = None,
    depth_range: Optional[tuple[float, float]] = None,
    force: bool = False,
    show_progress: bool = False,
) -> dict[str, list[float]]:
    """Reconstructs every triplet at every pyramid level (one task each) as
    ``vpctl mvs run --workspace W --triplets T --levels L --out OUT``: the
    same depth maps, in ``<out>/<triplet id>/level<L>/``. `triplets`: a
    triplet list file or its entries (``vpctl.labelgen.read_triplet_list``);
    `params`: any subset of ``vpctl mvs defaults``. Returns
    ``{"<id>/level<L>": share of pixels with a geometric depth per image}``.
    Refuses an existing `out` unless `force`; checks every image file first."""
    ws, out_p = Path(workspace), Path(out)
    _missing([ws, ws / "images", ws / "sparse"], "MVS workspace")
    # A path is a str or os.PathLike; anything else is the list's entries
    # (a str is a Sequence too: test for the path, not for the entries).
    if isinstance(triplets, (str, os.PathLike)):
        _missing([Path(triplets)], "triplet list")
        triplets = vpctl.labelgen.read_triplet_list(triplets)
    names = sorted({n for t in triplets for n in t["images"]})
    _missing([ws / "images" / n for n in names], "triplet images")
    if out_p.exists() and not force:
        raise FileExistsError(f"{out_p} exists; pass force=True to overwrite")
    jobs = [(vpctl.labelgen.triplet_id(i), t, level)
            for i, t in enumerate(triplets) for level in levels]
    with _client(client) as c:
        out_p.mkdir(parents=True, exist_ok=True)
        try:
            futures = [
                c.submit(_mvs_task, str(ws), list(t["images"]), int(level), str(out_p),
                         f"{tid}/level{level}", dict(params) if params else None, depth_range,
                         key=f"vpctl-mvs-{tid}-level{level}-{uuid.uuid4().hex[:8]}", pure=False)
                for tid, t, level in jobs
            ]
            results = _gather(c, futures, show_progress)
        finally:
            _remove_staging(out_p)
    return {f"{tid}/level{level}": r for (tid, _, level), r in zip(jobs, results)}


# --------------------------------------------------------------------------
# Labels


def _label_data(model: str, triplets: str, depth_dir: str, mesh: Optional[str],
                params: Optional[dict], frame_unchecked: bool):
    paths = [Path(model), Path(triplets), Path(depth_dir)] + ([Path(mesh)] if mesh else [])
    key = ("labels", model, triplets, depth_dir, mesh, repr(params), frame_unchecked, _stamp(*paths))
    return _cached(key, lambda: _native.LabelData.load(
        model, triplets, depth_dir, mesh, params, frame_unchecked))


def _references_task(args: tuple) -> dict:
    return _label_data(*args).references()


def _support_task(args: tuple, queries: list) -> dict:
    return dict(_label_data(*args).support(queries))


def _label_task(args: tuple, queries: list, out: str, *supports: dict) -> str:
    merged: dict = {}
    for s in supports:
        merged.update(s)
    out_p = Path(out)
    staging = _staging(out_p)
    summary = _label_data(*args).label(queries, merged, str(staging), True)
    _move_into(staging, out_p)
    return summary


def generate_labels(
    model: PathLike,
    triplets: PathLike,
    depth_dir: PathLike,
    out: PathLike,
    client: ClientLike = None,
    mesh: Optional[PathLike] = None,
    params: Optional[Mapping[str, Any]] = None,
    frame_unchecked: bool = False,
    chunk_size: Optional[int] = None,
    force: bool = False,
    show_progress: bool = False,
) -> dict[str, Any]:
    """Labels every view of every reconstruction as ``vpctl labelgen run
    --model --triplets --depth-dir --out-dir [--mesh --frame-unchecked]``:
    the same label files and ``summary.json`` (returned as a dict). Work
    splits into chunks of `chunk_size` reconstructions (default: about
    four chunks per worker); see the module docs for what is shared."""
    paths = [Path(model), Path(triplets), Path(depth_dir)] + ([Path(mesh)] if mesh else [])
    _missing(paths, "labelgen input")
    out_p = Path(out)
    _refuse_existing([out_p / "summary.json"], force)
    args = (str(model), str(triplets), str(depth_dir), str(mesh) if mesh else None,
            dict(params) if params else None, frame_unchecked)
    with _client(client) as c:
        refs = c.submit(_references_task, args, pure=False).result()
        ids = sorted(refs)
        n_workers = max(1, len(c.scheduler_info(n_workers=-1)["workers"]))
        size = chunk_size or max(1, -(-len(ids) // (4 * n_workers)))
        chunks = [ids[i:i + size] for i in range(0, len(ids), size)]
        chunk_of = {i: k for k, ch in enumerate(chunks) for i in ch}
        support = [c.submit(_support_task, args, ch, pure=False) for ch in chunks]
        out_p.mkdir(parents=True, exist_ok=True)
        try:
            labels = []
            for ch in chunks:
                needed = sorted({chunk_of[r] for q in ch for r in refs[q]})
                labels.append(c.submit(_label_task, args, ch, str(out_p),
                                       *[support[k] for k in needed], pure=False))
            summaries = _gather(c, support + labels, show_progress)[len(support):]
        finally:
            _remove_staging(out_p)
    return _native.write_summary(str(out_p), summaries)


# --------------------------------------------------------------------------
# Training


def _training_data(images: str, labels: str, seed: int, cap: Optional[int]):
    key = ("training", images, labels, seed, cap, _stamp(Path(images), Path(labels)))
    return _cached(key, lambda: _native.TrainingData.from_dirs(images, labels, seed, cap))


def _tree_task(images: str, labels: str, seed: int, cap: Optional[int],
               params: Optional[dict], index: int) -> bytes:
    return _training_data(images, labels, seed, cap).train_tree(index, params, seed)


def train_forest(
    images: PathLike,
    labels: PathLike,
    params: Optional[Mapping[str, Any]] = None,
    seed: int = 0,
    client: ClientLike = None,
    out: Optional[PathLike] = None,
    max_per_label_image: Optional[int] = None,
    force: bool = False,
    show_progress: bool = False,
) -> "vpctl.forest.Forest":
    """Trains the forest of ``vpctl train --images --labels --seed
    [--max-per-label-image]`` (parameters as a dict, any subset of ``vpctl
    forest defaults``) with one task per tree, and assembles it on the
    client: the same model bytes. Writes it to `out` atomically if given
    (refusing to overwrite unless `force`)."""
    _missing([Path(images), Path(labels)], "training input")
    if out is not None:
        _refuse_existing([Path(out)], force)
    p = dict(vpctl.forest.default_params())
    p.update(params or {})
    return _forest_of_tree_tasks(
        client, "tree", int(p["n_trees"]),
        lambda i: (_tree_task, str(images), str(labels), int(seed), max_per_label_image, p, i),
        out, show_progress)


def _forest_of_tree_tasks(
    client: ClientLike,
    name: str,
    n_trees: int,
    task_of: Callable[[int], tuple],
    out: Optional[PathLike],
    show_progress: bool,
) -> "vpctl.forest.Forest":
    """One task per tree (`task_of(i)`: the function and its arguments),
    keyed `vpctl-<name>-<i>-<random>`, gathered and assembled on the client
    in tree order; written to `out` if given (its refusal checked before)."""
    with _client(client) as c:
        futures = []
        for i in range(n_trees):
            fn, *args = task_of(i)
            futures.append(c.submit(fn, *args, key=f"vpctl-{name}-{i}-{uuid.uuid4().hex[:8]}",
                                    pure=False))
        trees = _gather(c, futures, show_progress)
    forest = _native.assemble(trees)
    if out is not None:
        forest.save(out, force=True)
    return forest


# --------------------------------------------------------------------------
# Prediction


def _predict_task(model: str, images: list, out: str, step: int, previews: bool) -> list:
    out_p = Path(out)
    staging = _staging(out_p)
    _native.predict_files(model, images, str(staging), step, previews, True)
    return [str(p) for p in _move_into(staging, out_p)]


def predict(
    model: PathLike,
    images: Sequence[PathLike],
    out: PathLike,
    client: ClientLike = None,
    step: int = 8,
    previews: bool = True,
    chunk_size: Optional[int] = None,
    force: bool = False,
    show_progress: bool = False,
) -> list[Path]:
    """Confidence images of `images` (files, or folders searched as ``vpctl
    predict`` searches them) into `out`, as ``vpctl predict --model --out
    [--step --no-previews]`` writes them, in chunks of `chunk_size` images.
    Returns the files written. Refuses to overwrite unless `force`."""
    _missing([Path(model)] + [Path(i) for i in images], "prediction input")
    found = _native.find_images([str(i) for i in images])
    names = [n for _, n in found]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"two images named {dup[0]} would write one confidence file")
    out_p = Path(out)
    _refuse_existing([out_p / f"{n}.vpconf" for n in names], force)
    with _client(client) as c:
        n_workers = max(1, len(c.scheduler_info(n_workers=-1)["workers"]))
        size = chunk_size or max(1, -(-len(found) // (4 * n_workers)))
        out_p.mkdir(parents=True, exist_ok=True)
        try:
            futures = [
                c.submit(_predict_task, str(model), [(str(p), n) for p, n in found[i:i + size]],
                         str(out_p), step, previews, pure=False)
                for i in range(0, len(found), size)
            ]
            written = _gather(c, futures, show_progress)
        finally:
            _remove_staging(out_p)
    return [Path(p) for chunk in written for p in chunk]


# --------------------------------------------------------------------------
# A site directory, end to end (the `vpctl-dask train` command)


def site_layout(workspace: PathLike) -> dict[str, Path]:
    """The files of a site directory for :func:`train_site`:
    ``dense/`` (COLMAP dense workspace, aligned: images/, sparse/,
    frame.json), ``triplets.txt`` (``vpctl labelgen triplets``), optionally
    ``mesh.ply`` (stage-3 negatives) and the configs ``mvs.toml``,
    ``labels.toml``, ``forest.toml``; written: ``depth/``, ``labels/``."""
    w = Path(workspace)
    return {
        "dense": w / "dense",
        "images": w / "dense" / "images",
        "model": w / "dense" / "sparse",
        "triplets": w / "triplets.txt",
        "mesh": w / "mesh.ply",
        "mvs_config": w / "mvs.toml",
        "label_config": w / "labels.toml",
        "forest_config": w / "forest.toml",
        "depth": w / "depth",
        "labels": w / "labels",
    }


def _toml(path: Path) -> Optional[dict]:
    if not path.is_file():
        return None
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib  # type: ignore[no-redef, import-not-found, unused-ignore]
    with open(path, "rb") as f:
        return tomllib.load(f)


def train_site(
    workspace: PathLike,
    out: PathLike,
    client: ClientLike = None,
    levels: Sequence[int] = (1, 2, 3),
    seed: int = 0,
    max_per_label_image: Optional[int] = None,
    frame_unchecked: bool = False,
    force: bool = False,
    show_progress: bool = False,
) -> "vpctl.forest.Forest":
    """The whole offline training of a site directory (:func:`site_layout`)
    on one cluster: triplet MVS, labels, forest, model file `out`."""
    s = site_layout(workspace)
    _missing([s["dense"], s["images"], s["model"], s["triplets"]], "site directory")
    if not force:
        _refuse_existing([Path(out)], False)
    mesh = s["mesh"] if s["mesh"].is_file() else None
    with _client(client) as c:
        reconstruct_triplets(s["dense"], s["triplets"], levels, s["depth"], client=c,
                             params=_toml(s["mvs_config"]), force=force, show_progress=show_progress)
        generate_labels(s["model"], s["triplets"], s["depth"], s["labels"], client=c, mesh=mesh,
                        params=_toml(s["label_config"]), frame_unchecked=frame_unchecked,
                        force=force, show_progress=show_progress)
        return train_forest(s["images"], s["labels"], params=_toml(s["forest_config"]), seed=seed,
                            client=c, out=out, max_per_label_image=max_per_label_image,
                            force=force, show_progress=show_progress)


# The patch store's two calls live in their own module (this one's helpers,
# imported once these exist).
from vpctl._dask_store import train_forest_from_store, write_patch_store  # noqa: E402
