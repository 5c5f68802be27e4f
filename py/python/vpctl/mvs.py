"""`vpctl.mvs`: see the stub `mvs.pyi` for signatures and the Rust crate vp-mvs for details."""

import os as _os

from vpctl._native import mvs as _native_mvs

__all__ = ["reconstruct"]


def _existing(value, name, kind):
    path = _os.fspath(value)
    ok = _os.path.isdir(path) if kind == "folder" else _os.path.isfile(path)
    if not ok:
        raise FileNotFoundError(f"{name}: no such {kind}: {path!r}")
    return path


def reconstruct(workspace, *, images=None, triplets=None, levels=(1,), out=None,
                depth_range=None, params=None, seed=None, force=False):
    """Dense multi-view stereo (vp-mvs, CPU PatchMatch) on a COLMAP dense
    workspace, writing exactly the files ``vpctl mvs run`` writes for the
    same arguments (same inputs and seed, same bytes).

    Without ``triplets`` (``vpctl mvs run --workspace W [--images]``): every
    image (or each of ``images``) against its best source images; writes
    ``stereo/depth_maps``, ``stereo/normal_maps`` and ``fused.ply`` into the
    workspace and returns ``{"reconstructed", "geometric_valid_share",
    "fused_points", "fused_path"}``.

    With ``triplets`` (a list written by ``vpctl labelgen triplets``) and
    ``out`` (``--triplets T --levels L --out OUT``): each triplet on its own
    at each pyramid level into ``<out>/<triplet id>/level<L>/``, the layout
    ``vpctl labelgen run`` reads; returns ``{triplet id: {level: [share of
    pixels with a geometric depth per image]}}``.

    ``depth_range``: ``(min, max)`` along the optical axis for every image
    (needed when the model has no 3D points). ``params``: a dict with any
    subset of ``vpctl mvs defaults``; ``seed`` overrides its seed.
    ``force``: overwrite ``fused.ply`` or the ``out`` folder.

    Raises ``FileNotFoundError`` for a missing workspace, triplet file or
    image, ``FileExistsError`` for existing output without ``force`` and
    ``ValueError`` for bad arguments or unusable inputs (distorted model,
    image size not its camera's, a triplet naming unknown images, ...);
    the message names the argument or file.
    """
    ws = _existing(workspace, "workspace", "folder")
    if depth_range is not None:
        try:
            lo, hi = (float(v) for v in depth_range)
        except (TypeError, ValueError):
            raise ValueError(f"depth_range: expected (min, max), got {depth_range!r}") from None
        depth_range = (lo, hi)
    if triplets is None:
        if out is not None:
            raise ValueError("out: only used with triplets (the workspace run writes into workspace)")
        if images is not None:
            if isinstance(images, (str, bytes)):
                raise ValueError(f"images: expected a list of image names, got {images!r}")
            images = [str(n) for n in images]
        return _native_mvs.run_workspace(ws, images, depth_range, params, seed, force)
    if images is not None:
        raise ValueError("images: not used with triplets (each triplet names its images)")
    if out is None:
        raise ValueError("out: required with triplets (the depth folder vpctl labelgen run reads)")
    if isinstance(levels, int):
        levels = [levels]
    levels = list(levels)
    if not levels or any(not isinstance(v, int) or isinstance(v, bool) or v < 1 for v in levels):
        raise ValueError(f"levels: expected pyramid levels >= 1 (1 = full size), got {levels!r}")
    tri = _existing(triplets, "triplets", "file")
    return _native_mvs.run_triplets(ws, tri, _os.fspath(out), levels, depth_range, params, seed, force)
