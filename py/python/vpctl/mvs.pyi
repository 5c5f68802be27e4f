"""Dense multi-view stereo on the CPU (vp-mvs, PatchMatch) on a COLMAP dense workspace."""

from os import PathLike
from typing import Any, Mapping, Optional, Sequence, Union

_Path = Union[str, PathLike[str]]

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
) -> dict[str, Any]:
    """Runs ``vpctl mvs run`` on `workspace` (with `triplets` and `out`:
    ``--triplets --levels --out``) and returns its summary; writes the same
    files, byte for byte, for the same inputs and seed."""
    ...
