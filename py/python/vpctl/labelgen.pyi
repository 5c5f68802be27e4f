"""Triplet sampling and training labels from depth maps (vp-labelgen)."""

from os import PathLike
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Union, final

import numpy.typing as npt

from vpctl.scene import Camera, ColmapModel, Mesh, RayCaster

_Path = Union[str, PathLike[str]]

__all__ = [
    "Labels",
    "TripletReconstruction",
    "depth_map_path",
    "generate_labels",
    "load_reconstructions",
    "read_triplet_list",
    "run",
    "sample_triplets",
    "sparse_model",
    "triplet_id",
    "write_triplet_list",
]

@final
class TripletReconstruction:
    def __new__(cls, id: str, views: Sequence[tuple[str, Camera, npt.ArrayLike]]) -> TripletReconstruction: ...
    @property
    def id(self) -> str: ...
    @property
    def names(self) -> list[str]: ...

@final
class Labels:
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> dict[str, Any]: ...
    def summary(self) -> dict[str, Any]: ...
    def write(self, out_dir: _Path, force: bool = False) -> dict[str, Any]: ...

def sample_triplets(
    model: ColmapModel,
    per_bin: int = 10,
    seed: int = 0,
    min_shared_points: int = 20,
    min_shared_share: float = 0.1,
    min_equilateral: float = 0.5,
    bin_edges: Optional[Sequence[float]] = None,
) -> list[dict[str, Any]]: ...
def write_triplet_list(path: _Path, triplets: Sequence[Mapping[str, Any]], force: bool = False) -> None: ...
def read_triplet_list(path: _Path) -> list[dict[str, Any]]: ...
def triplet_id(i: int) -> str: ...
def depth_map_path(depth_dir: _Path, id: str, level: int, image: str) -> Path: ...
def sparse_model(
    cameras: Sequence[tuple[str, Camera]], caster: RayCaster, pts: npt.ArrayLike
) -> ColmapModel: ...
def load_reconstructions(
    model: ColmapModel, triplets: Sequence[Mapping[str, Any]], depth_dir: _Path
) -> list[TripletReconstruction]: ...
def generate_labels(
    reconstructions: Sequence[TripletReconstruction],
    mesh: Optional[Mesh] = None,
    params: Optional[Mapping[str, Any]] = None,
) -> Labels: ...

def run(
    model: _Path,
    triplets: _Path,
    depth_dir: _Path,
    out: _Path,
    mesh: Optional[_Path] = None,
    params: Optional[Mapping[str, Any]] = None,
    frame_unchecked: bool = False,
    force: bool = False,
) -> dict[str, Any]: ...
