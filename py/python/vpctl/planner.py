"""`vpctl.planner`: see the stub `planner.pyi` for signatures and the Rust crate vp-planner for details."""

from vpctl._native import planner as _native_planner

__all__ = [n for n in dir(_native_planner) if not n.startswith("_")]
globals().update({n: getattr(_native_planner, n) for n in __all__})
