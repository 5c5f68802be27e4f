"""vpctl.mvs.reconstruct on the committed real photo sequence
(tests/data/real-mvs/visp-cube): the same files, byte for byte, as `vpctl
mvs run` for the same inputs and seed, for a workspace run and a triplet
run; errors that name the argument or file."""

import shutil
from pathlib import Path

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
