"""`vpctl.sim`: see the stub `sim.pyi` for signatures and the Rust crate vp-sim for details."""

from vpctl._native import sim as _native_sim

__all__ = [n for n in dir(_native_sim) if not n.startswith("_")]
globals().update({n: getattr(_native_sim, n) for n in __all__})
