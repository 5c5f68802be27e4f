"""vpctl: plan UAV image acquisition for dense multi-view stereo.

Python bindings of the vpctl Rust crates, one submodule per crate:

- :mod:`vpctl.scene`: meshes, cameras, COLMAP models, procedural sites,
  ray casting and clearance;
- :mod:`vpctl.forest`: the confidence forest (train, predict, save/load, metrics);
- :mod:`vpctl.labelgen`: triplet sampling and training labels from depth maps;
- :mod:`vpctl.planner`: the paper's planner (M1-M4) and the grid baseline;
- :mod:`vpctl.mission`: MAVLink missions, QGC export, upload/download, a simulated vehicle;
- :mod:`vpctl.sim`: rendering and a virtual MVS;
- :mod:`vpctl.mvs`: dense multi-view stereo on the CPU (PatchMatch) on a
  COLMAP dense workspace or on triplets, the files ``vpctl mvs run`` writes;
- :mod:`vpctl.distributed` (not imported here; needs the ``dask`` extra):
  triplet MVS, labels, training and prediction as Dask tasks.

Arrays are numpy; long calls release the GIL; Rust errors arrive as
``ValueError`` (bad values or file contents), ``OSError`` (files, links),
``TimeoutError`` (no answer from a vehicle) or ``RuntimeError`` (a refused plan).
"""

from vpctl import forest, labelgen, mission, mvs, planner, scene, sim
from vpctl._native import __version__

__all__ = ["__version__", "forest", "labelgen", "mission", "mvs", "planner", "scene", "sim"]
