from vpctl import forest as forest
from vpctl import labelgen as labelgen
from vpctl import mission as mission
from vpctl import mvs as mvs
from vpctl import planner as planner
from vpctl import scene as scene
from vpctl import sim as sim

__version__: str

__all__ = ["__version__", "forest", "labelgen", "mission", "mvs", "planner", "scene", "sim"]
