"""`vpctl.forest`: see the stub `forest.pyi` for signatures and the Rust crate vp-forest for details."""

from vpctl._native import forest as _native_forest

__all__ = [n for n in dir(_native_forest) if not n.startswith("_")]
globals().update({n: getattr(_native_forest, n) for n in __all__})
