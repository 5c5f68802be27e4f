"""Dense multi-view stereo on the CPU (vp-mvs: PatchMatch or semi-global matching) on a COLMAP dense workspace."""

from os import PathLike
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

from vpctl.scene import Camera

_Path = Union[str, PathLike[str]]

__all__ = [
    "patch_match",
    "reconstruct",
]

def reconstruct(
    workspace: _Path,
    *,
    images: Optional[Sequence[str]] = None,
    triplets: Optional[_Path] = None,
    levels: Union[int, Sequence[int]] = (1,),
    out: Optional[_Path] = None,
    depth_range: Optional[tuple[float, float]] = None,
    params: Optional[Mapping[str, Any]] = None,
    seed: Optional[int] = None,
    force: bool = False,
    algorithm: Optional[Literal["patchmatch", "sgm"]] = None,
    progress: Union[Callable[[str], Any], bool, None] = None,
) -> dict[str, Any]:
    """Runs ``vpctl mvs run`` on `workspace` (with `triplets` and `out`:
    ``--triplets --levels --out``; `algorithm`: ``--algorithm``) and returns
    its summary; writes the same files, byte for byte, for the same inputs
    and seed. `progress`: lines on stderr (None), silent (False) or a
    callable taking each line."""
    ...

def patch_match(
    images: Sequence[npt.ArrayLike],
    cameras: Sequence[Camera],
    depth_ranges: Union[tuple[float, float], Sequence[tuple[float, float]]],
    *,
    sources: Optional[Sequence[Sequence[int]]] = None,
    params: Optional[Mapping[str, Any]] = None,
    seed: Optional[int] = None,
    filtered: bool = True,
    algorithm: Optional[Literal["patchmatch", "sgm"]] = None,
    progress: Union[Callable[[str], Any], bool, None] = None,
) -> list[Optional[tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32]]]]:
    """PatchMatch on images in memory: per image (depth (H, W), normal
    (H, W, 3), cost (H, W)) float32 arrays, geometrically filtered when
    `filtered`; ``None`` for an image without sources. Same inputs and seed,
    same arrays."""
    ...
