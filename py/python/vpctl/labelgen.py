"""`vpctl.labelgen`: see the stub `labelgen.pyi` for signatures and the Rust crate vp-labelgen for details."""

from vpctl._native import labelgen as _native_labelgen

__all__ = [n for n in dir(_native_labelgen) if not n.startswith("_")]
globals().update({n: getattr(_native_labelgen, n) for n in __all__})
