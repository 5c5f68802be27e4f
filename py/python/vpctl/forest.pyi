"""The confidence forest: train, predict, save/load, metrics (vp-forest)."""

from os import PathLike
from typing import Any, Mapping, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]

__all__ = [
    "ConfidenceImage",
    "Forest",
    "accuracy",
    "default_params",
    "sparsification",
    "train",
    "train_dirs",
]

@final
class ConfidenceImage:
    def __new__(
        cls,
        values: npt.ArrayLike,
        width: int,
        height: int,
        step: int,
        gamma_max_deg: float = 45.0,
    ) -> ConfidenceImage: ...
    @staticmethod
    def constant(value: float) -> ConfidenceImage: ...
    @staticmethod
    def load(path: _Path) -> ConfidenceImage: ...
    def save(self, path: _Path, force: bool = False) -> None: ...
    @property
    def values(self) -> npt.NDArray[np.float32]: ...
    @property
    def step(self) -> int: ...
    @property
    def size(self) -> tuple[int, int]: ...
    @property
    def bin_edges(self) -> list[float]: ...
    def sample(
        self, pixels: npt.ArrayLike, angles_deg: npt.ArrayLike
    ) -> npt.NDArray[np.float32]: ...

@final
class Forest:
    @staticmethod
    def load(path: _Path) -> Forest: ...
    def save(self, path: _Path, force: bool = False) -> None: ...
    def to_bytes(self) -> bytes: ...
    @property
    def n_trees(self) -> int: ...
    @property
    def params(self) -> dict[str, Any]: ...
    @property
    def summary(self) -> dict[str, Any]: ...
    def predict(self, image: npt.ArrayLike, step: int = 8) -> ConfidenceImage: ...
    def score(
        self, image: npt.ArrayLike, labels: npt.ArrayLike, angles: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.bool_]]: ...

def train(
    images: Sequence[npt.ArrayLike],
    labels: Sequence[npt.ArrayLike],
    angles: Sequence[npt.ArrayLike],
    params: Optional[Mapping[str, Any]] = None,
    seed: int = 0,
    max_per_label_image: Optional[int] = None,
) -> Forest: ...
def train_dirs(
    images_dir: _Path,
    labels_dir: _Path,
    params: Optional[Mapping[str, Any]] = None,
    seed: int = 0,
    max_per_label_image: Optional[int] = None,
) -> Forest: ...
def default_params(preset: str = "default") -> dict[str, Any]: ...
def accuracy(confidence: npt.ArrayLike, positive: npt.ArrayLike, threshold: float = 0.5) -> float: ...
def sparsification(
    confidence: npt.ArrayLike, positive: npt.ArrayLike, curve_points: int = 100
) -> dict[str, Any]: ...
