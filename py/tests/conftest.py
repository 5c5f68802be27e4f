"""Shared fixtures: small seeded scenes, and the vpctl binary for the
tests that compare Python with the command line."""

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import vpctl


def vpctl_bin() -> str:
    """The vpctl binary: $VPCTL_BIN, else `vpctl` on PATH. Missing means
    skip, except in CI (VP_REQUIRE_VPCTL=1), where it is a failure."""
    path = os.environ.get("VPCTL_BIN") or shutil.which("vpctl")
    if path and Path(path).is_file():
        return path
    if os.environ.get("VP_REQUIRE_VPCTL") == "1":
        pytest.fail("VP_REQUIRE_VPCTL=1 but no vpctl binary (set VPCTL_BIN)")
    pytest.skip("no vpctl binary (set VPCTL_BIN to compare with the CLI)")


def run_cli(*args: str) -> subprocess.CompletedProcess:
    """Runs vpctl; fails the test with its stderr when it exits non-zero."""
    p = subprocess.run([vpctl_bin(), *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return p


@pytest.fixture(scope="session")
def site():
    """A 20k-face procedural site (seed 2), as the CLI plan tests use."""
    return vpctl.scene.generate_site(seed=2, faces=20_000)


def heightfield(n: int = 40, spacing: float = 2.0) -> vpctl.scene.Mesh:
    """A wavy n x n heightfield centred on the origin, with a box on it."""
    xs = (np.arange(n) - (n - 1) / 2) * spacing
    gx, gy = np.meshgrid(xs, xs)
    gz = 1.5 * np.sin(gx / 12.0) * np.cos(gy / 10.0)
    verts = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    faces = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            faces += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    lo, hi = np.array([3.0, -10.0, -1.0]), np.array([9.0, -4.0, 6.0])
    corners = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    base = len(verts)
    box = [
        [0, 2, 1], [1, 2, 3],  # bottom (z-)
        [4, 5, 6], [5, 7, 6],  # top (z+)
        [0, 1, 4], [1, 5, 4],  # y-
        [2, 6, 3], [3, 6, 7],  # y+
        [0, 4, 2], [2, 4, 6],  # x-
        [1, 3, 5], [3, 7, 5],  # x+
    ]
    verts = np.vstack([verts, corners])
    faces = np.array(faces + [[base + a, base + b, base + c] for a, b, c in box], dtype=np.int64)
    return vpctl.scene.Mesh(verts, faces)


def files_under(root: Path) -> dict:
    """Relative path -> bytes of every data file under root. The CLI's
    `.vpctl-output.json` (its record of what it wrote, so that --force
    replaces only that) is bookkeeping, not output, and is left out."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != ".vpctl-output.json"
    }
