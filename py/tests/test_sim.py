"""vpctl.sim: rendering and the virtual MVS."""

import numpy as np
import pytest

import vpctl
from conftest import files_under, run_cli


@pytest.fixture(scope="module")
def world(site):
    mesh = site.mesh
    caster = vpctl.scene.RayCaster(mesh)
    lo, hi = site.rock_bounds
    c = (lo + hi) / 2
    cams = [
        vpctl.scene.Camera.look_at(80, 60, 60.0, [c[0] + dx, c[1] - 25.0, hi[2] + 20.0], c.tolist())
        for dx in (-4.0, 0.0, 4.0)
    ]
    return mesh, caster, cams, c.tolist()


def test_render_images(world):
    mesh, caster, cams, _ = world
    r = vpctl.sim.render(mesh, caster, cams[1])
    assert r["rgb"].shape == (60, 80, 3) and r["rgb"].dtype == np.uint8
    assert r["depth"].shape == (60, 80) and r["face_id"].shape == (60, 80)
    hit = r["depth"] > 0
    assert hit.mean() > 0.5
    # Pixels without a surface show the sky colour.
    assert np.all(r["rgb"][~hit] == r["rgb"][~hit][0])
    assert np.all(r["face_id"][hit] >= 0) and np.all(r["face_id"][hit] < mesh.n_faces)
    depth, face = caster.render_depth(cams[1])
    assert np.allclose(r["depth"], depth, rtol=1e-5)
    assert np.array_equal(r["face_id"], face)
    again = vpctl.sim.render(mesh, caster, cams[1])
    assert np.array_equal(again["rgb"], r["rgb"])
    other = vpctl.sim.render(mesh, caster, cams[1], params={"texture_seed": 99})
    assert not np.array_equal(other["rgb"], r["rgb"])
    with pytest.raises(ValueError):
        vpctl.sim.render(mesh, caster, cams[1], params={"ambient": -1.0})
    with pytest.raises(ValueError, match="no_such"):
        vpctl.sim.render(mesh, caster, cams[1], params={"no_such": 1})
    with pytest.raises(ValueError, match="faces"):
        vpctl.sim.render(vpctl.scene.generate_site(seed=1, faces=10_000).mesh, caster, cams[1])


def test_virtual_mvs(world):
    mesh, caster, cams, _ = world
    mvs = vpctl.sim.VirtualMvs("sure")
    maps = mvs.reconstruct(mesh, caster, cams, level=1, seed=3)
    assert len(maps) == 3 and all(m.shape == (60, 80) for m in maps)
    valid = [(m > 0).mean() for m in maps]
    assert all(0.0 < v < 1.0 for v in valid)
    def median_error(triplet, seed):
        d = mvs.reconstruct(mesh, caster, triplet, seed=seed)[0]
        truth, _ = caster.render_depth(triplet[0])
        ok = (d > 0) & (truth > 0)
        return np.median(np.abs(d[ok] - truth[ok]) / truth[ok])

    # Depth noise follows the triplet's 3D uncertainty: a wider baseline
    # (larger triangulation angle) gives smaller errors.
    wide = [vpctl.scene.Camera.look_at(80, 60, 60.0, (np.array(c.center) + off).tolist(), world[3])
            for c, off in zip(cams, ([-4.0, 0, 0], [0, 0, 0], [4.0, 0, 0]))]
    narrow_err, wide_err = median_error(cams, 3), median_error(wide, 3)
    assert narrow_err < 0.2 and wide_err < narrow_err
    assert all(np.array_equal(a, b) for a, b in zip(maps, mvs.reconstruct(mesh, caster, cams, seed=3)))
    assert not np.array_equal(maps[0], mvs.reconstruct(mesh, caster, cams, seed=4)[0])
    half = mvs.reconstruct(mesh, caster, cams, level=2, seed=3)
    assert half[0].shape == (30, 40)
    assert vpctl.sim.VirtualMvs("pmvs").profile["name"] != mvs.profile["name"]
    with pytest.raises(ValueError, match="profile"):
        vpctl.sim.VirtualMvs("colmap")
    with pytest.raises(ValueError, match="3"):
        mvs.reconstruct(mesh, caster, cams[:2])


def test_fly_writes_the_cli_flight_byte_for_byte(tmp_path):
    """vpctl.sim.fly is the front door `vpctl sim fly` calls: the same plan
    and site give the same images, COLMAP model and frame.json, byte for
    byte (noisy SfM poses included), and the same refusals."""
    # The camera stated: `plan` fills a missing one from the planner's
    # defaults, `sim fly` from the demo preset.
    (tmp_path / "site.toml").write_text("[site]\nseed = 3\ntarget_faces = 8000\nsize = 40.0\n"
                                        "[planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n")
    run_cli("scene", "generate", "--config", tmp_path / "site.toml", "--out", tmp_path / "site.ply")
    run_cli("plan", "grid", "--mesh", tmp_path / "site.ply", "--config", tmp_path / "site.toml",
            "--height", "35", "--overlap", "0.6", "--out", tmp_path / "g.json")
    run_cli("sim", "fly", tmp_path / "g.json", "--site", tmp_path / "site.toml",
            "--out", tmp_path / "cli", "--output-type", "bin")
    s = vpctl.sim.fly([tmp_path / "g.json"], tmp_path / "site.toml", tmp_path / "py",
                      output_type="bin")
    got, want = files_under(tmp_path / "py"), files_under(tmp_path / "cli")
    assert got.keys() == want.keys()
    assert {"sparse/cameras.bin", "sparse/images.bin", "sparse/points3D.bin",
            "sparse/frame.json", "images/g_0000.png"} <= got.keys()
    for rel in want:
        assert got[rel] == want[rel], rel
    assert s["images"] == sum(k.startswith("images/") for k in got) > 3
    assert s["points"] > 0 and s["min_views"] >= 2
    with pytest.raises(ValueError, match="earlier `vpctl sim fly`"):
        vpctl.sim.fly([tmp_path / "g.json"], tmp_path / "site.toml", tmp_path / "py")
    with pytest.raises(ValueError, match="output_type"):
        vpctl.sim.fly([tmp_path / "g.json"], tmp_path / "site.toml", tmp_path / "x",
                      output_type="ply")
    with pytest.raises(ValueError, match="clash"):
        vpctl.sim.fly([tmp_path / "g.json"] * 2, tmp_path / "site.toml", tmp_path / "x")
    assert not (tmp_path / "x").exists()
