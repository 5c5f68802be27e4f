"""The patch store on Dask (re-exported by :mod:`vpctl.distributed`):
:func:`write_patch_store` writes the samples training draws once as a
chunked store on shared storage; :func:`train_forest_from_store` trains one
task per tree, each streaming the store in bounded memory."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Optional

import vpctl
from vpctl._native import distributed as _native

if TYPE_CHECKING:
    from vpctl.distributed import ClientLike, PathLike

# vpctl.distributed's helpers are imported where used: a worker unpickling
# a task of this module imports it first, and vpctl.distributed imports it.

__all__ = ["train_forest_from_store", "write_patch_store"]


def write_patch_store(
    images: PathLike,
    labels: PathLike,
    out: PathLike,
    params: Optional[Mapping[str, Any]] = None,
    seed: int = 0,
    max_per_label_image: Optional[int] = None,
    chunk_len: int = 16384,
    force: bool = False,
) -> dict:
    """Writes the samples ``vpctl train --images --labels --seed`` would
    draw with `params` as a patch store at `out` (chunk files of
    `chunk_len` 27x27 Lab patches, labels, angles, ``manifest.json``),
    atomically; returns the manifest. One job on this machine: it loads the
    training set as :func:`train_forest`'s tasks do, once."""
    import json

    from vpctl.distributed import _missing

    _missing([Path(images), Path(labels)], "training input")
    p = dict(vpctl.forest.default_params())
    p.update(params or {})
    text = _native.PatchStore.write(str(images), str(labels), str(out), p, int(seed),
                                    max_per_label_image, int(chunk_len), force)
    return json.loads(text)


def _patch_store(store: str):
    from vpctl.distributed import _cached, _stamp

    key = ("store", store, _stamp(Path(store) / "manifest.json"))
    return _cached(key, lambda: _native.PatchStore.open(store))


def _store_tree_task(store: str, params: dict, budget_mb: int, index: int) -> bytes:
    tree, _reads = _patch_store(store).train_tree(index, params, budget_mb)
    return tree


def train_forest_from_store(
    store: PathLike,
    params: Optional[Mapping[str, Any]] = None,
    client: ClientLike = None,
    out: Optional[PathLike] = None,
    budget_mb: int = 4096,
    force: bool = False,
    show_progress: bool = False,
) -> "vpctl.forest.Forest":
    """Trains the forest of a patch store (:func:`write_patch_store`) with
    one task per tree, each holding at most `budget_mb` MiB of patches plus
    one chunk, and assembles it on the client: the same model bytes as
    :func:`train_forest` on the data, parameters and seed the store was
    written with. Writes it to `out` atomically if given."""
    from vpctl.distributed import _forest_of_tree_tasks, _refuse_existing

    if out is not None:
        _refuse_existing([Path(out)], force)
    # Opened here too: a missing or corrupt store fails before any task.
    _native.PatchStore.open(str(store))
    p = dict(vpctl.forest.default_params())
    p.update(params or {})
    return _forest_of_tree_tasks(
        client, "store-tree", int(p["n_trees"]),
        lambda i: (_store_tree_task, str(store), p, int(budget_mb), i),
        out, show_progress)
