"""MAVLink missions, QGC export, upload/download, a simulated vehicle (vp-mission)."""

from os import PathLike
from types import TracebackType
from typing import Any, Optional, Union, final

from vpctl.planner import Plan

_Path = Union[str, PathLike[str]]

_Home = Union[tuple[float, float, float], tuple[float, float, float, str]]

__all__ = [
    "Mission",
    "SimulatedVehicle",
    "build_mission",
    "clear",
    "download",
    "export",
    "upload",
]

@final
class Mission:
    @property
    def items(self) -> list[dict[str, Any]]: ...
    @property
    def photos(self) -> int: ...
    @property
    def autopilot(self) -> str: ...
    def to_wpl(self) -> str: ...
    def __len__(self) -> int: ...

@final
class SimulatedVehicle:
    def __new__(
        cls,
        bind: str = "127.0.0.1:0",
        autopilot: str = "px4",
        home: tuple[float, float, float] | None = None,
    ) -> SimulatedVehicle: ...
    @property
    def url(self) -> str: ...
    def mission(self) -> list[dict[str, Any]]: ...
    def upload_counts(self) -> tuple[int, int]: ...
    def close(self) -> None: ...
    def __enter__(self) -> SimulatedVehicle: ...
    def __exit__(
        self,
        t: Optional[type[BaseException]],
        v: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

def build_mission(
    plan: Plan,
    autopilot: str = "px4",
    hold: float = 2.0,
    speed: Optional[float] = None,
    takeoff: float = 20.0,
    rtl: bool = True,
    home: Optional[_Home] = None,
    ceiling: float = 120.0,
    min_height: float = 2.0,
) -> Mission: ...
def export(
    plan: Plan,
    format: Optional[str] = None,
    out: Optional[_Path] = None,
    force: bool = False,
    autopilot: str = "px4",
    hold: float = 2.0,
    speed: Optional[float] = None,
    takeoff: float = 20.0,
    rtl: bool = True,
    home: Optional[_Home] = None,
    ceiling: float = 120.0,
    min_height: float = 2.0,
    drone: Optional[str] = None,
    dji_heights: str = "relative",
    split: bool = False,
) -> Union[str, bytes, list[str], list[bytes]]: ...
def upload(
    plan: Plan,
    url: str,
    heartbeat_timeout: float = 5.0,
    timeout_scale: float = 1.0,
    autopilot: str = "px4",
    hold: float = 2.0,
    speed: Optional[float] = None,
    takeoff: float = 20.0,
    rtl: bool = True,
    home: Optional[_Home] = None,
    ceiling: float = 120.0,
    min_height: float = 2.0,
    flight: Optional[int] = None,
    accept_home_offset: bool = False,
) -> dict[str, Any]: ...
def download(url: str, heartbeat_timeout: float = 5.0, timeout_scale: float = 1.0) -> list[dict[str, Any]]: ...
def clear(url: str, heartbeat_timeout: float = 5.0, timeout_scale: float = 1.0) -> None: ...
