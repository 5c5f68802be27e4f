"""vpctl.mvs: reconstruct on the committed real photo sequence
(tests/data/real-mvs/visp-cube) writes the same files, byte for byte, as
`vpctl mvs run` for the same inputs and seed, for a workspace run and a
triplet run; patch_match on rendered images in memory returns depth, normal
and cost arrays near the truth; errors name the argument or file."""

import shutil
from pathlib import Path

import numpy as np
import pytest

import vpctl
from conftest import files_under, run_cli

DATA = Path(__file__).resolve().parents[2] / "tests/data/real-mvs/visp-cube"
IMAGES = ["cube_23.png", "cube_30.png", "cube_36.png"]
# One iteration and a sparser window keep the full-size run at seconds.
PARAMS = {"iterations": 1, "window_step": 3}
TOML = "iterations = 1\nwindow_step = 3\n"
SEED = 3


def workspace(tmp_path: Path, name: str) -> Path:
    ws = tmp_path / name
    shutil.copytree(DATA, ws)
    return ws


def test_workspace_run_writes_the_cli_files_byte_for_byte(tmp_path):
    before = files_under(DATA)
    ws_py, ws_cli = workspace(tmp_path, "py"), workspace(tmp_path, "cli")
    summary = vpctl.mvs.reconstruct(ws_py, images=IMAGES, params=PARAMS, seed=SEED)
    (tmp_path / "mvs.toml").write_text(TOML)
    run_cli("mvs", "run", "--workspace", ws_cli, "--images", ",".join(IMAGES),
            "--config", tmp_path / "mvs.toml", "--seed", SEED)

    got, want = files_under(ws_py), files_under(ws_cli)
    assert sorted(got) == sorted(want)
    for kind in ("depth_maps", "normal_maps"):
        for name in IMAGES:
            for m in ("photometric", "geometric"):
                assert f"stereo/{kind}/{name}.{m}.bin" in got
    assert "fused.ply" in got
    for rel in want:
        assert got[rel] == want[rel], rel
    assert summary["reconstructed"] == IMAGES
    assert all(s > 0.5 for s in summary["geometric_valid_share"]), summary
    assert summary["fused_points"] > 1000
    assert Path(summary["fused_path"]) == ws_py / "fused.ply"
    assert files_under(DATA) == before

    with pytest.raises(FileExistsError, match="fused.ply"):
        vpctl.mvs.reconstruct(ws_py, images=IMAGES, params=PARAMS, seed=SEED)
    other = vpctl.mvs.reconstruct(ws_py, images=IMAGES, params=PARAMS, seed=SEED + 1, force=True)
    assert other["reconstructed"] == IMAGES
    assert files_under(ws_py)["fused.ply"] != want["fused.ply"], "the seed is not used"


def test_sgm_workspace_run_writes_the_cli_files_byte_for_byte(tmp_path):
    # algorithm="sgm" is `vpctl mvs run --algorithm sgm`: the same library
    # entry, so the same bytes; and not PatchMatch's bytes.
    ws_py, ws_cli, ws_pm = (workspace(tmp_path, n) for n in ("py", "cli", "pm"))
    summary = vpctl.mvs.reconstruct(ws_py, images=IMAGES, seed=SEED, algorithm="sgm")
    run_cli("mvs", "run", "--workspace", ws_cli, "--images", ",".join(IMAGES),
            "--algorithm", "sgm", "--seed", SEED)
    got, want = files_under(ws_py), files_under(ws_cli)
    assert sorted(got) == sorted(want)
    for rel in want:
        assert got[rel] == want[rel], rel
    assert summary["reconstructed"] == IMAGES
    assert all(s > 0.2 for s in summary["geometric_valid_share"]), summary
    assert summary["fused_points"] > 1000
    vpctl.mvs.reconstruct(ws_pm, images=IMAGES, params=PARAMS, seed=SEED, algorithm="patchmatch")
    name = f"stereo/depth_maps/{IMAGES[0]}.photometric.bin"
    assert files_under(ws_pm)[name] != got[name], "algorithm is not used"
    with pytest.raises(ValueError, match="algorithm"):
        vpctl.mvs.reconstruct(ws_py, images=IMAGES, algorithm="census", force=True)


def test_triplet_run_writes_the_cli_depth_folder_byte_for_byte(tmp_path):
    ws = workspace(tmp_path, "ws")
    t = tmp_path / "t.txt"
    run_cli("labelgen", "triplets", "--model", ws / "sparse", "--out", t,
            "--per-bin", "1", "--min-equilateral", "0.45")
    shares = vpctl.mvs.reconstruct(ws, triplets=t, levels=[3], out=tmp_path / "py",
                                   params=PARAMS, seed=SEED)
    (tmp_path / "mvs.toml").write_text(TOML)
    run_cli("mvs", "run", "--workspace", ws, "--triplets", t, "--levels", "3",
            "--out", tmp_path / "cli", "--config", tmp_path / "mvs.toml", "--seed", SEED)

    got, want = files_under(tmp_path / "py"), files_under(tmp_path / "cli")
    assert got.keys() == want.keys()
    assert len(got) == 3 * 3 * 2  # triplets x images x (photometric, geometric)
    for rel in want:
        assert got[rel] == want[rel], rel
    assert sorted(shares) == ["t0000", "t0001", "t0002"]
    for tid, per_level in shares.items():
        assert list(per_level) == [3]
        assert len(per_level[3]) == 3 and all(0.3 < s <= 1.0 for s in per_level[3]), (tid, per_level)
    # The workspace itself is only read.
    assert not (ws / "fused.ply").exists() and not (ws / "stereo/depth_maps").exists()


def test_errors_name_the_argument_or_file(tmp_path):
    ws = workspace(tmp_path, "ws")
    with pytest.raises(FileNotFoundError, match="workspace"):
        vpctl.mvs.reconstruct(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="triplets"):
        vpctl.mvs.reconstruct(ws, triplets=tmp_path / "none.txt", out=tmp_path / "d")
    with pytest.raises(ValueError, match="out"):
        vpctl.mvs.reconstruct(ws, triplets=tmp_path / "none.txt")
    with pytest.raises(ValueError, match="levels"):
        vpctl.mvs.reconstruct(ws, triplets=tmp_path / "none.txt", out=tmp_path / "d", levels=[0])
    with pytest.raises(ValueError, match="depth_range"):
        vpctl.mvs.reconstruct(ws, depth_range=5.0)
    with pytest.raises(ValueError, match="nope.png"):
        vpctl.mvs.reconstruct(ws, images=["cube_23.png", "nope.png"], params=PARAMS)
    with pytest.raises(ValueError, match="depth range"):
        vpctl.mvs.reconstruct(ws, images=IMAGES, depth_range=(5.0, 1.0), params=PARAMS)
    with pytest.raises(ValueError, match="params"):
        vpctl.mvs.reconstruct(ws, images=IMAGES, params={"iterations": "many"})
    t = tmp_path / "t.txt"
    t.write_text("# vpctl labelgen triplets v1\n0\t7.0\tcube_23.png\tcube_30.png\tghost.png\n")
    with pytest.raises(ValueError, match=r"t\.txt.*ghost\.png|ghost\.png.*t\.txt"):
        vpctl.mvs.reconstruct(ws, triplets=t, out=tmp_path / "d", params=PARAMS)
    assert not (tmp_path / "d").exists()
    assert not (ws / "fused.ply").exists() and not (ws / "stereo/depth_maps").exists()


def rendered_triplet(site, size=(96, 72)):
    """Three rendered views of the site's rock, about 10 deg apart."""
    mesh = site.mesh
    caster = vpctl.scene.RayCaster(mesh)
    lo, hi = site.rock_bounds
    c = (lo + hi) / 2
    cams = [
        vpctl.scene.Camera.look_at(*size, 60.0, [c[0] + dx, c[1] - 20.0, hi[2] + 15.0], c.tolist())
        for dx in (-2.5, 0.0, 2.5)
    ]
    renders = [vpctl.sim.render(mesh, caster, cam) for cam in cams]
    return cams, renders


def test_patch_match_in_memory_returns_maps_near_the_truth(site):
    # 128 x 96, not 96 x 72: at 96 x 72 the worst view's median error sits
    # at 0.91-1.00 % for seeds 1-8, the matcher's precision floor there, so
    # the 1 % bar below read noise; at 128 x 96 it is 0.64-0.70 %.
    cams, renders = rendered_triplet(site, size=(128, 96))
    images = [r["rgb"] for r in renders]
    truth = [r["depth"] for r in renders]
    valid = np.concatenate([t[t > 0] for t in truth])
    depth_range = (0.8 * valid.min(), 1.2 * valid.max())
    sources = [[1, 2], [0, 2], [0, 1]]
    params = {"iterations": 3}
    maps = vpctl.mvs.patch_match(images, cams, depth_range, sources=sources, params=params, seed=1)
    assert len(maps) == 3
    for (depth, normal, cost), t in zip(maps, truth):
        assert depth.shape == (96, 128) and depth.dtype == np.float32
        assert normal.shape == (96, 128, 3) and cost.shape == (96, 128)
        kept = depth > 0
        assert kept.mean() > 0.2, kept.mean()
        # Unit normals where a depth is kept, zero elsewhere.
        assert np.allclose(np.linalg.norm(normal[kept], axis=1), 1.0, atol=1e-4)
        assert np.all(normal[~kept] == 0)
        ok = kept & (t > 0)
        rel = np.abs(depth[ok] - t[ok]) / t[ok]
        assert np.median(rel) < 0.01, np.median(rel)
    # Same inputs and seed, same arrays; the photometric maps keep more.
    again = vpctl.mvs.patch_match(images, cams, depth_range, sources=sources, params=params, seed=1)
    for a, b in zip(maps, again):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)
    photo = vpctl.mvs.patch_match(images, cams, depth_range, sources=sources, params=params,
                                  seed=1, filtered=False)
    assert sum((p[0] > 0).sum() for p in photo) >= sum((m[0] > 0).sum() for m in maps)


def test_patch_match_errors_name_the_argument(site):
    cams, renders = rendered_triplet(site, size=(32, 24))
    images = [r["rgb"] for r in renders]
    with pytest.raises(ValueError, match="cameras"):
        vpctl.mvs.patch_match(images, cams[:2], (5.0, 50.0))
    with pytest.raises(ValueError, match="depth range"):
        vpctl.mvs.patch_match(images, cams, (50.0, 5.0))
    with pytest.raises(ValueError, match="depth_ranges"):
        vpctl.mvs.patch_match(images, cams, [(5.0, 50.0)] * 2)
    with pytest.raises(ValueError, match="images\\[1\\]"):
        vpctl.mvs.patch_match([images[0], images[1][:10], images[2]], cams, (5.0, 50.0))
    with pytest.raises(ValueError, match="source"):
        vpctl.mvs.patch_match(images, cams, (5.0, 50.0), sources=[[1], [7], [0]])


def test_progress_lines_go_to_stderr_a_callable_or_nowhere(site, capfd):
    """A long call says where it is, as the CLI does (issue 40): by default
    `[vpctl] <line>` on stderr, each line to a callable, nothing with
    ``progress=False``; an exception in the callable reaches the caller."""
    cams, renders = rendered_triplet(site, size=(32, 24))
    images = [r["rgb"] for r in renders]
    args = (images, cams, (5.0, 50.0))
    kw = {"sources": [[1, 2], [0, 2], [0, 1]], "params": {"iterations": 1}, "seed": 1}
    capfd.readouterr()
    vpctl.mvs.patch_match(*args, **kw)
    default = [l for l in capfd.readouterr().err.splitlines() if l.startswith("[vpctl] ")]
    assert default, "no progress line on stderr by default"
    heard = []
    vpctl.mvs.patch_match(*args, **kw, progress=heard.append)
    assert heard == [l[len("[vpctl] "):] for l in default]
    vpctl.mvs.patch_match(*args, **kw, progress=False)
    assert "[vpctl]" not in capfd.readouterr().err

    def fails(line):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        vpctl.mvs.patch_match(*args, **kw, progress=fails)
    with pytest.raises(TypeError, match="progress"):
        vpctl.mvs.patch_match(*args, **kw, progress=42)
