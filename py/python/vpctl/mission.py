"""`vpctl.mission`: see the stub `mission.pyi` for signatures and the Rust crate vp-mission for details."""

from vpctl._native import mission as _native_mission

__all__ = [n for n in dir(_native_mission) if not n.startswith("_")]
globals().update({n: getattr(_native_mission, n) for n in __all__})
