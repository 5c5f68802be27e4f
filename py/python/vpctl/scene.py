"""`vpctl.scene`: see the stub `scene.pyi` for signatures and the Rust crate vp-scene for details."""

from vpctl._native import scene as _native_scene

__all__ = [n for n in dir(_native_scene) if not n.startswith("_")]
globals().update({n: getattr(_native_scene, n) for n in __all__})
