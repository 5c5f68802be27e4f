# The compiled extension. Its submodules are re-exported, and typed, by
# vpctl.forest, vpctl.planner, ... (their .pyi stubs); vpctl.distributed
# alone reaches into it, for its task functions.
from typing import Any

__version__: str
scene: Any
forest: Any
labelgen: Any
planner: Any
mission: Any
sim: Any
mvs: Any
distributed: Any

__all__ = ["__version__", "scene", "forest", "labelgen", "planner", "mission", "sim", "mvs", "distributed"]
