"""Rendering, a virtual MVS and closed-loop campaigns (vp-sim)."""

from os import PathLike
from typing import Any, Callable, Mapping, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

from vpctl.scene import Camera, Mesh, RayCaster

__all__ = [
    "VirtualMvs",
    "campaign_config",
    "fly",
    "render",
    "run_campaign",
]

@final
class VirtualMvs:
    def __new__(cls, profile: Union[str, Mapping[str, Any], None] = None) -> VirtualMvs: ...
    @property
    def profile(self) -> dict[str, Any]: ...
    def reconstruct(
        self,
        mesh: Mesh,
        caster: RayCaster,
        cameras: Sequence[Camera],
        level: int = 1,
        seed: int = 0,
    ) -> list[npt.NDArray[np.float32]]: ...

def render(
    mesh: Mesh,
    caster: RayCaster,
    camera: Camera,
    params: Optional[Mapping[str, Any]] = None,
) -> dict[str, npt.NDArray[Any]]: ...
def fly(
    plans: Sequence[Union[str, PathLike[str]]],
    site: Union[str, PathLike[str]],
    out: Union[str, PathLike[str]],
    exact: bool = False,
    output_type: str = "txt",
    max_points: int = 20000,
    force: bool = False,
    progress: Union[Callable[[str], Any], bool, None] = None,
) -> dict[str, Any]: ...
def campaign_config(
    config: Union[Mapping[str, Any], str, PathLike[str], None] = None, preset: str = "demo"
) -> dict[str, Any]: ...
def run_campaign(
    config: Union[Mapping[str, Any], str, PathLike[str], None] = None,
    preset: str = "demo",
    progress: Union[Callable[[str], Any], bool, None] = None,
) -> list[dict[str, Any]]: ...
