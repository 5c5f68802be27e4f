"""`vpctl.mvs`: see the stub `mvs.pyi` for signatures and the Rust crate vp-mvs for details."""

import numbers as _numbers
import os as _os

from vpctl._native import mvs as _native_mvs

__all__ = ["patch_match", "reconstruct"]


def _existing(value, name, kind):
    path = _os.fspath(value)
    ok = _os.path.isdir(path) if kind == "folder" else _os.path.isfile(path)
    if not ok:
        raise FileNotFoundError(f"{name}: no such {kind}: {path!r}")
    return path


_ALGORITHMS = ("patchmatch", "sgm")


def _algorithm(value):
    if value is not None and value not in _ALGORITHMS:
        raise ValueError(f"algorithm: expected one of {', '.join(_ALGORITHMS)}, got {value!r}")
    return value


def reconstruct(workspace, *, images=None, triplets=None, levels=(1,), out=None,
                depth_range=None, params=None, seed=None, force=False, algorithm=None,
                progress=None):
    """Dense multi-view stereo (vp-mvs on the CPU: PatchMatch, or
    semi-global matching with ``algorithm="sgm"``) on a COLMAP dense
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
    ``algorithm``: ``"patchmatch"`` or ``"sgm"`` (``vpctl mvs run
    --algorithm``), over ``params``'s ``algorithm``; the semi-global
    matcher's parameters are ``params["sgm"]`` (the ``[sgm]`` table).
    ``force``: overwrite ``fused.ply``, or replace an earlier output in
    ``out`` (only the files vpctl wrote there, as ``vpctl mvs run``; a
    non-empty folder vpctl did not write is refused with ``ValueError``).
    ``progress``: each step as a line on ``sys.stderr`` (``None``, the
    default), nothing (``False``), or passed to a callable taking one str.

    Raises ``FileNotFoundError`` for a missing workspace, triplet file or
    image, ``FileExistsError`` for existing output without ``force`` and
    ``ValueError`` for bad arguments or unusable inputs (distorted model,
    image size not its camera's, a triplet naming unknown images, ...);
    the message names the argument or file.
    """
    algorithm = _algorithm(algorithm)
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
        return _native_mvs.run_workspace(ws, images, depth_range, params, seed, force, algorithm,
                                         progress)
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
    return _native_mvs.run_triplets(ws, tri, _os.fspath(out), levels, depth_range, params, seed, force,
                                    algorithm, progress)


def patch_match(images, cameras, depth_ranges, *, sources=None, params=None, seed=None,
                filtered=True, algorithm=None, progress=None):
    """PatchMatch multi-view stereo on images in memory (vp-mvs's
    ``reconstruct``: PatchMatch per image, the geometric pass and filter).

    ``images``: (H, W, 3) uint8 arrays; ``cameras``: one posed
    :class:`vpctl.scene.Camera` per image, of the image's size;
    ``depth_ranges``: ``(min, max)`` along the optical axis, one per image or
    one for all; ``sources``: ``sources[i]`` lists the source images of image
    ``i`` (default: the cameras whose frusta overlap most, at least
    ``min_triangulation_angle_deg`` apart). ``params``: any subset of
    ``vpctl mvs defaults``; ``seed`` overrides its seed; ``algorithm="sgm"``
    runs the semi-global matcher instead of PatchMatch (cost 0 everywhere:
    it has no NCC to report).

    Returns, per image, ``(depth, normal, cost)``: float32 arrays (H, W),
    (H, W, 3) (unit normals in the camera frame) and (H, W) (1 - NCC of the
    winner), with depth 0 and normal 0 where a filter rejected the pixel;
    geometrically filtered maps when ``filtered`` (else PatchMatch's
    photometric maps); ``None`` for an image without sources. Same inputs
    and seed, same arrays.

    Raises ``ValueError`` for mismatched lengths, an image whose size is not
    its camera's, an empty or inverted depth range, or unknown source indices.
    """
    images = list(images)
    cameras = list(cameras)
    if len(depth_ranges) == 2 and all(isinstance(v, _numbers.Real) for v in depth_ranges):
        depth_ranges = [depth_ranges]
    try:
        depth_ranges = [(float(lo), float(hi)) for lo, hi in depth_ranges]
    except (TypeError, ValueError):
        raise ValueError(f"depth_ranges: expected (min, max) or a list of them, got {depth_ranges!r}") from None
    if sources is not None:
        sources = [[int(s) for s in src] for src in sources]
    return _native_mvs.patch_match(images, cameras, depth_ranges, sources, params, seed, bool(filtered),
                                   _algorithm(algorithm), progress)
