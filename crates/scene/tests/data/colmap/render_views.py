"""Render a few pinhole views of a textured toy scene for a tiny COLMAP SfM run.

Scene (world z up, metres): a 10 m x 10 m ground square textured with
skimage's astronaut photo and two boxes textured with other skimage photos.
Views: four 320x240 ideal pinhole cameras (f = 300 px, principal point at
the image centre) at azimuths -24, -8, 8, 24 deg on a circle of radius 8 m
around (-2, 0), 5 m up, all looking at (0, 0, 0.5).
Every pixel is ray cast (2x2 supersampled), so the views are exact
perspective images of one 3D scene. Deterministic: no randomness.

usage: python render_views.py OUT_DIR
"""
import sys
import os

import numpy as np
from PIL import Image
from skimage import data

W, H, F = 320, 240, 300.0
SS = 2  # supersampling per axis


def texture(img):
    img = np.asarray(img, dtype=np.float32)
    if img.ndim == 2:
        img = np.stack([img] * 3, axis=-1)
    return img[..., :3]


GROUND = texture(data.astronaut())  # 512 x 512
BOXES = [
    # (min corner, max corner, texture)
    (np.array([-1.5, -1.0, 0.0]), np.array([0.5, 1.0, 1.5]), texture(data.coffee())),
    (np.array([1.5, -2.5, 0.0]), np.array([2.7, -1.3, 2.2]), texture(data.chelsea())),
]
SKY = np.array([128.0, 128.0, 128.0], dtype=np.float32)


def sample(tex, u, v):
    """Texture lookup, u, v in [0, 1]; nearest texel."""
    h, w = tex.shape[:2]
    x = np.clip((u * (w - 1)).round().astype(int), 0, w - 1)
    y = np.clip((v * (h - 1)).round().astype(int), 0, h - 1)
    return tex[y, x]


def look_at(center, target):
    z = target - center
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)  # world_from_cam rotation (columns)


def render(center, target):
    rot = look_at(center, target)
    ys, xs = np.mgrid[0 : H * SS, 0 : W * SS]
    px = (xs + 0.5) / SS
    py = (ys + 0.5) / SS
    d_cam = np.stack([(px - W / 2) / F, (py - H / 2) / F, np.ones_like(px)], axis=-1)
    d = d_cam @ rot.T
    n = d.shape[:2]
    t_best = np.full(n, np.inf)
    color = np.broadcast_to(SKY, n + (3,)).copy()

    # Ground z = 0 inside [-5, 5]^2.
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -center[2] / d[..., 2]
    p = center + t[..., None] * d
    hit = (t > 0) & (np.abs(p[..., 0]) <= 5) & (np.abs(p[..., 1]) <= 5)
    c = sample(GROUND, (p[..., 0] + 5) / 10, (5 - p[..., 1]) / 10)
    color[hit] = c[hit]
    t_best[hit] = t[hit]

    for lo, hi, tex in BOXES:
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - center) / d
            t2 = (hi - center) / d
        tmin = np.minimum(t1, t2)
        tmax = np.maximum(t1, t2)
        t_near = np.nanmax(tmin, axis=-1)
        t_far = np.nanmin(tmax, axis=-1)
        axis = np.nanargmax(tmin, axis=-1)
        hit = (t_near <= t_far) & (t_near > 0) & (t_near < t_best)
        p = center + t_near[..., None] * d
        rel = (p - lo) / (hi - lo)
        # Texture coordinates from the two axes other than the face normal;
        # each face gets its own quarter of the photo so no two look alike.
        u = np.where(axis == 0, rel[..., 1], rel[..., 0])
        v = np.where(axis == 2, rel[..., 1], 1 - rel[..., 2])
        quarter_u = np.where(axis == 1, 0.5, 0.0)
        face_hi = np.take_along_axis(rel, axis[..., None], -1)[..., 0] > 0.5
        uu = 0.5 * u + quarter_u
        vv = 0.5 * v + np.where(face_hi, 0.5, 0.0)
        c = sample(tex, uu, vv)
        color[hit] = c[hit]
        t_best[hit] = t_near[hit]

    img = color.reshape(H, SS, W, SS, 3).mean(axis=(1, 3))
    return Image.fromarray(img.clip(0, 255).astype(np.uint8))


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    target = np.array([0.0, 0.0, 0.5])
    for i, az in enumerate(np.radians(np.arange(-24, 25, 16))):
        center = np.array([8 * np.cos(az) - 2.0, 8 * np.sin(az), 5.0])
        render(center, target).save(os.path.join(out, f"view_{i:02d}.png"))


if __name__ == "__main__":
    main()
