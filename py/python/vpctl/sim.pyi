"""Rendering and a virtual MVS (vp-sim)."""

from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

from vpctl.scene import Camera, Mesh, RayCaster

class VirtualMvs:
    def __init__(self, profile: Union[str, Mapping[str, Any], None] = None) -> None: ...
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
