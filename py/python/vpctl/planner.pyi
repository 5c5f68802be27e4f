"""The paper's planner (M1-M4) and the grid baseline (vp-planner)."""

from os import PathLike
from typing import Any, Mapping, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

from vpctl.forest import ConfidenceImage
from vpctl.scene import Camera, ColmapModel, Mesh

_Path = Union[str, PathLike[str]]
_Config = Union[Mapping[str, Any], _Path, None]
_Roi = Union[Sequence[float], Mapping[str, Any], None]

__all__ = [
    "Plan",
    "PlanResult",
    "default_config",
    "default_config_toml",
    "plan",
    "plan_cameras",
    "plan_grid",
]

@final
class Plan:
    @staticmethod
    def load(path: _Path) -> Plan: ...
    @staticmethod
    def from_json(text: str) -> Plan: ...
    def save(self, path: _Path, force: bool = False, no_timings: bool = False) -> None: ...
    def to_json(self, no_timings: bool = False) -> str: ...
    def to_dict(self, no_timings: bool = False) -> dict[str, Any]: ...
    @property
    def waypoints(self) -> list[dict[str, Any]]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def angles(self) -> npt.NDArray[np.float64]: ...
    @property
    def cut_short_reason(self) -> Optional[str]: ...
    def __len__(self) -> int: ...

@final
class PlanResult:
    @property
    def plan(self) -> Plan: ...
    @property
    def iterations(self) -> list[dict[str, Any]]: ...
    @property
    def triplet_gains(self) -> list[float]: ...
    @property
    def module_time_s(self) -> dict[str, float]: ...
    @property
    def cut_short_reason(self) -> Optional[str]: ...
    @property
    def dropped_triplets(self) -> list[int]: ...
    @property
    def dropped_reasons(self) -> list[str]: ...
    @property
    def sampled(self) -> dict[str, npt.NDArray[Any]]: ...

def plan(
    mesh: Union[Mesh, _Path],
    cameras: Union[ColmapModel, _Path, Sequence[Camera]],
    confidence: Union[_Path, Sequence[Optional[ConfidenceImage]], None] = None,
    config: _Config = None,
    roi: _Roi = None,
    origin: Optional[tuple[float, float, float]] = None,
    datum: Optional[str] = None,
    home: Union[tuple[float, float, float], tuple[float, float, float, str], str, None] = None,
    frame_unchecked: bool = False,
    roi_polygon: Optional[_Path] = None,
    roi_name: Optional[str] = None,
    roi_heights: Optional[tuple[float, float]] = None,
) -> PlanResult: ...
def plan_grid(
    mesh: Union[Mesh, _Path],
    roi: _Roi = None,
    height: float = 50.0,
    gsd: Optional[float] = None,
    overlap: float = 0.8,
    side_overlap: Optional[float] = None,
    pitch: float = -90.0,
    yaw: float = 0.0,
    initial: bool = False,
    config: _Config = None,
    origin: Optional[tuple[float, float, float]] = None,
    datum: Optional[str] = None,
    home: Union[tuple[float, float, float], tuple[float, float, float, str], None] = None,
    roi_polygon: Optional[_Path] = None,
    roi_name: Optional[str] = None,
    roi_heights: Optional[tuple[float, float]] = None,
) -> Plan: ...
def default_config() -> dict[str, Any]: ...
def default_config_toml() -> str: ...
def plan_cameras(plan: Plan, config: _Config = None) -> list[Camera]: ...
