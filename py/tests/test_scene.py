"""vpctl.scene: sites, meshes, cameras, COLMAP models, ray casting, clearance."""

import numpy as np
import pytest

import vpctl
from conftest import run_cli, heightfield


def plane(size: float = 10.0, z: float = 0.0) -> vpctl.scene.Mesh:
    v = np.array([[-size, -size, z], [size, -size, z], [size, size, z], [-size, size, z]])
    return vpctl.scene.Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]))


def test_generate_site_counts_and_determinism(site):
    s = site.summary()
    mesh = site.mesh
    assert s["n_faces"] == mesh.n_faces
    assert abs(mesh.n_faces - 20_000) <= 2_000
    assert sum(s["faces_per_material"].values()) == mesh.n_faces
    assert set(s["faces_per_material"]) == set(vpctl.scene.material_names())
    mats = mesh.materials
    assert mats.shape == (mesh.n_faces,) and mats.dtype == np.uint8
    rock = vpctl.scene.material_names().index("rock")
    assert np.count_nonzero(mats == rock) == s["faces_per_material"]["rock"]
    lo, hi = site.rock_bounds
    assert np.all(hi > lo)
    again = vpctl.scene.generate_site(seed=2, faces=20_000)
    assert np.array_equal(again.mesh.vertices, mesh.vertices)
    other = vpctl.scene.generate_site(seed=3, faces=20_000)
    assert not np.array_equal(other.mesh.vertices[:100], mesh.vertices[:100])


def test_generate_site_keywords_and_bad_values():
    s = vpctl.scene.generate_site(seed=1, faces=10_000, n_trees=0, n_markers=2)
    assert s.summary()["n_trees"] == 0 and s.summary()["n_markers"] == 2
    assert s.params["n_trees"] == 0
    with pytest.raises(ValueError, match="target_faces"):
        vpctl.scene.generate_site(faces=10)
    with pytest.raises(ValueError, match="rock_width"):
        vpctl.scene.generate_site(faces=10_000, rock_width=30.0)
    with pytest.raises(ValueError):
        vpctl.scene.generate_site(faces=10_000, no_such_parameter=1)


def test_site_save_equals_cli_scene_generate(tmp_path):
    cli = tmp_path / "cli.ply"
    run_cli("scene", "generate", "--seed", "5", "--faces", "20000", "--out", cli)
    py = tmp_path / "py.ply"
    vpctl.scene.generate_site(seed=5, faces=20_000).save(py)
    assert py.read_bytes() == cli.read_bytes()
    ascii_cli = tmp_path / "cli_ascii.ply"
    run_cli("scene", "generate", "--seed", "5", "--faces", "20000", "--format", "ply-ascii", "--out", ascii_cli)
    ascii_py = tmp_path / "py_ascii.ply"
    vpctl.scene.generate_site(seed=5, faces=20_000).save(ascii_py, format="ply-ascii")
    assert ascii_py.read_bytes() == ascii_cli.read_bytes()


def test_mesh_save_load_round_trip_and_overwrite(tmp_path, site):
    p = tmp_path / "site.ply"
    site.mesh.save(p)
    back = vpctl.scene.Mesh.load(p)
    assert back.n_faces == site.mesh.n_faces
    assert np.array_equal(back.faces, site.mesh.faces)
    assert np.array_equal(back.materials, site.mesh.materials)
    assert np.allclose(back.vertices, site.mesh.vertices, atol=1e-4)
    with pytest.raises(FileExistsError):
        site.mesh.save(p)
    site.mesh.save(p, force=True)
    obj = tmp_path / "site.obj"
    site.mesh.save(obj)
    assert vpctl.scene.Mesh.load(obj).n_faces == site.mesh.n_faces


def test_mesh_bad_inputs(tmp_path):
    with pytest.raises(FileNotFoundError):
        vpctl.scene.Mesh.load(tmp_path / "missing.ply")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat nonsense\n")
    with pytest.raises(ValueError, match="bad.ply"):
        vpctl.scene.Mesh.load(bad)
    with pytest.raises(ValueError, match="unknown mesh format"):
        plane().save(tmp_path / "x.ply", format="stl")
    v = np.zeros((3, 3))
    with pytest.raises(ValueError):
        vpctl.scene.Mesh(v, np.array([[0, 1, 5]]))
    with pytest.raises(ValueError, match="faces"):
        vpctl.scene.Mesh(v, np.array([[0, 1]]))
    with pytest.raises(ValueError, match="vertices"):
        vpctl.scene.Mesh(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="materials"):
        vpctl.scene.Mesh(np.eye(3), np.array([[0, 1, 2]]), np.array([99], dtype=np.uint8))


def test_ray_casting_batch_hits_plane_at_height():
    caster = vpctl.scene.RayCaster(plane(z=1.0))
    origins = np.array([[0.0, 0.0, 5.0], [2.0, -3.0, 11.0], [50.0, 50.0, 5.0]])
    dirs = np.array([[0.0, 0.0, -2.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    hits = caster.closest_hits(origins, dirs)
    assert hits["t"].shape == (3,)
    assert hits["t"][0] == pytest.approx(4.0, abs=1e-5)
    assert hits["t"][1] == pytest.approx(10.0, abs=1e-5)
    assert np.isinf(hits["t"][2]) and hits["face"][2] == -1
    assert set(hits["face"][:2]) <= {0, 1}
    assert np.allclose(hits["points"][:2, 2], 1.0, atol=1e-5)
    assert np.all(np.isnan(hits["points"][2]))
    short = caster.closest_hits(origins, dirs, t_max=5.0)
    assert np.isfinite(short["t"][0]) and np.isinf(short["t"][1])
    occ = caster.occluded(np.array([[0, 0, 5.0], [0, 0, 5.0]]), np.array([[0, 0, -5.0], [0, 0, 2.0]]))
    assert occ.tolist() == [True, False]
    with pytest.raises(ValueError, match="zero length"):
        caster.closest_hits(origins[:1], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="origins"):
        caster.closest_hits(origins[:2], dirs)
    with pytest.raises(ValueError):
        caster.closest_hits(np.array([[np.nan, 0, 0]]), dirs[:1])


def test_ray_caster_and_clearance_take_array_likes():
    """Issue 40: `closest_hits([[0,0,50]], [[0,0,-1]])` raised "'list' object
    is not an instance of 'ndarray'" and float32 arrays "type mismatch:
    from=float32, to=float64", though the stubs promise array-likes."""
    caster = vpctl.scene.RayCaster(plane(z=1.0))
    ref = caster.closest_hits(np.array([[0.0, 0.0, 50.0]]), np.array([[0.0, 0.0, -1.0]]))
    for o, d in [
        ([[0, 0, 50]], [[0, 0, -1]]),
        (np.array([[0, 0, 50]], dtype=np.float32), np.array([[0, 0, -1]], dtype=np.float32)),
        (np.array([[0, 0, 50]], dtype=np.int32), ((0, 0, -1),)),
        # A strided view (every other row of a Fortran-ordered array).
        (np.asfortranarray(np.array([[0.0, 0, 50], [9, 9, 9]]))[::2], [[0, 0, -1.0]]),
    ]:
        hits = caster.closest_hits(o, d)
        assert hits["t"][0] == pytest.approx(49.0, abs=1e-5)
        assert hits["face"][0] == ref["face"][0]
    occ = caster.occluded([[0, 0, 5], [0, 0, 5]], np.array([[0, 0, -5], [0, 0, 2]], dtype=np.float32))
    assert occ.tolist() == [True, False]
    c = vpctl.scene.Clearance(plane(z=0.0))
    assert np.allclose(c.distance([[0, 0, 3]]), [3.0], atol=1e-6)
    assert c.points_clear(np.array([[0, 0, 3]], dtype=np.float32), 1.0).tolist() == [True]
    assert c.segments_clear([[0, 0, 3]], [[5, 0, 0.2]], 1.0).tolist() == [False]
    # Errors name the argument, the expected shape and dtype.
    with pytest.raises(ValueError, match=r"directions: expected an \(N, 3\) array of real numbers \(float64\), got shape \(3,\)"):
        caster.closest_hits([[0, 0, 50]], [0, 0, -1])
    with pytest.raises(TypeError, match=r"origins: expected an \(N, 3\) array of real numbers \(float64\), got dtype <U1"):
        caster.closest_hits([["a", "b", "c"]], [[0, 0, -1]])
    with pytest.raises(ValueError, match=r"b: expected an \(N, 3\)"):
        c.segments_clear([[0, 0, 3]], [[5, 0]], 1.0)
    cam = vpctl.scene.Camera.look_at(64, 48, 60.0, [0, 0, 10], [0, 0, 0])
    o, d = cam.rays([[32, 24]])
    assert np.allclose(d, [[0, 0, -1]], atol=1e-9)
    with pytest.raises(ValueError, match=r"pixels: expected an \(N, 2\)"):
        cam.rays([[1, 2, 3]])


def test_camera_projection_and_depth_render():
    cam = vpctl.scene.Camera.look_at(64, 48, 60.0, [0.0, -1.0, 10.0], [0.0, 0.0, 1.0])
    assert cam.size == (64, 48)
    fx, fy, cx, cy = cam.intrinsics
    px = cam.project(np.array([[0.0, 0.0, 1.0]]))
    assert np.allclose(px[0], [cx, cy], atol=1e-6)
    assert np.allclose(cam.center, [0.0, -1.0, 10.0])
    m = cam.world_from_cam
    again = vpctl.scene.Camera(64, 48, fx, fy, cx, cy, m)
    assert np.allclose(again.project(np.array([[1.0, 2.0, 1.0]])), cam.project(np.array([[1.0, 2.0, 1.0]])))
    caster = vpctl.scene.RayCaster(plane(z=1.0))
    depth, face = caster.render_depth(cam)
    assert depth.shape == (48, 64) and face.shape == (48, 64)
    assert np.all(depth > 0) and np.all(face >= 0)
    with pytest.raises(ValueError, match="rotation"):
        vpctl.scene.Camera(64, 48, fx, fy, cx, cy, 2 * np.eye(4))
    # Straight down is the aerial view, not an error (see below); the same
    # point twice is.
    with pytest.raises(ValueError):
        vpctl.scene.Camera.look_at(64, 48, 60.0, [0.0, 0.0, 10.0], [0.0, 0.0, 10.0])


def test_clearance_distances():
    c = vpctl.scene.Clearance(plane(z=0.0))
    pts = np.array([[0.0, 0.0, 3.0], [1.0, 1.0, 0.5]])
    assert np.allclose(c.distance(pts), [3.0, 0.5], atol=1e-6)
    assert c.points_clear(pts, 1.0).tolist() == [True, False]
    a, b = np.array([[0.0, 0.0, 3.0]]), np.array([[5.0, 0.0, 0.2]])
    assert c.segments_clear(a, b, 1.0).tolist() == [False]
    assert c.segments_clear(a, b, 0.1).tolist() == [True]
    with pytest.raises(ValueError, match="radius"):
        c.points_clear(pts, -1.0)


def test_colmap_model_and_depth_map_round_trip(tmp_path):
    mesh = heightfield()
    caster = vpctl.scene.RayCaster(mesh)
    cams = [
        (f"img{i}.jpg", vpctl.scene.Camera.look_at(96, 72, 60.0, [-6.0 + 4 * i, 0.5, 30.0], [0.0, 0.0, 0.0]))
        for i in range(4)
    ]
    model = vpctl.labelgen.sparse_model(cams, caster, mesh.vertices[::3])
    assert model.image_names == [n for n, _ in cams]
    assert len(model.points) > 50
    model.save(tmp_path / "bin")
    model.save(tmp_path / "txt", format="text")
    for d in ("bin", "txt"):
        back = vpctl.scene.ColmapModel.load(tmp_path / d)
        assert back.image_names == model.image_names
        assert np.allclose(back.points, model.points)
        for (_, c), b in zip(cams, back.cameras()):
            assert np.allclose(b.world_from_cam, c.world_from_cam, atol=1e-9)
    with pytest.raises(ValueError, match="format"):
        model.save(tmp_path / "x", format="json")
    with pytest.raises(OSError):
        vpctl.scene.ColmapModel.load(tmp_path / "nothing")
    depth, _ = caster.render_depth(cams[0][1])
    vpctl.scene.write_depth_map(tmp_path / "d.bin", depth)
    assert np.array_equal(vpctl.scene.read_depth_map(tmp_path / "d.bin"), depth)


def test_array_likes_are_converted_once_at_the_boundary(tmp_path):
    """The stubs promise npt.ArrayLike: lists, float32 vertices and int32
    faces (what open3d gives) were refused."""
    v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    ref = vpctl.scene.Mesh(np.array(v), np.array([[0, 1, 2]]))
    for verts, faces in [
        (v, [[0, 1, 2]]),
        (np.array(v, dtype=np.float32), np.array([[0, 1, 2]], dtype=np.int32)),
        (np.asfortranarray(np.array(v)), np.array([[0, 1, 2]], dtype=np.uint16)),
        (tuple(map(tuple, v)), ((0, 1, 2),)),
    ]:
        m = vpctl.scene.Mesh(verts, faces, [0])
        assert np.array_equal(m.vertices, ref.vertices) and np.array_equal(m.faces, ref.faces)
    # Errors name the argument: TypeError for what is not numbers of the
    # right kind (float indices are not truncated), ValueError for shapes.
    with pytest.raises(TypeError, match="faces"):
        vpctl.scene.Mesh(v, [[0.0, 1.0, 2.0]])
    with pytest.raises(TypeError, match="vertices"):
        vpctl.scene.Mesh([["a", "b", "c"]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="faces"):
        vpctl.scene.Mesh(v, [0, 1, 2])
    cam = vpctl.scene.Camera.look_at(64, 48, 60.0, [0, 0, 10], [0, 0, 0])
    assert np.allclose(cam.project([[0.0, 0.0, 0.0]]), [[32.0, 24.0]])
    with pytest.raises(ValueError, match="pts"):
        cam.project([1.0, 2.0, 3.0])
    # write_depth_map takes float64 too; every writer refuses to overwrite.
    d = np.full((4, 5), 2.0)
    vpctl.scene.write_depth_map(tmp_path / "d.bin", d)
    assert np.array_equal(vpctl.scene.read_depth_map(tmp_path / "d.bin"), d.astype(np.float32))
    with pytest.raises(FileExistsError):
        vpctl.scene.write_depth_map(tmp_path / "d.bin", d)
    vpctl.scene.write_depth_map(tmp_path / "d.bin", d, force=True)


def test_look_at_straight_down_is_the_aerial_view():
    """Camera.look_at refused the normal aerial view (straight down)."""
    cam = vpctl.scene.Camera.look_at(64, 48, 60.0, [3.0, 4.0, 30.0], [3.0, 4.0, 0.0])
    r = cam.world_from_cam[:3, :3]
    assert np.allclose(r[:, 2], [0, 0, -1])  # optical axis down
    assert np.allclose(r[:, 0], [1, 0, 0])   # image x east
    assert np.allclose(cam.project([[3.0, 4.0, 0.0]]), [[32.0, 24.0]])
    with pytest.raises(ValueError, match="center"):
        vpctl.scene.Camera.look_at(64, 48, 60.0, [1, 1, 1], [1, 1, 1])


def test_colmap_save_refuses_to_overwrite_and_takes_the_cli_names(tmp_path):
    mesh = heightfield()
    caster = vpctl.scene.RayCaster(mesh)
    cams = [(f"i{i}.png", vpctl.scene.Camera.look_at(64, 48, 60.0, [i, 0.5, 20.0], [0.0, 0.0, 0.0]))
            for i in range(3)]
    model = vpctl.labelgen.sparse_model(cams, caster, mesh.vertices[::5])
    model.save(tmp_path / "m", format="txt")
    assert (tmp_path / "m" / "images.txt").is_file()
    with pytest.raises(FileExistsError):
        model.save(tmp_path / "m", format="text")
    model.save(tmp_path / "m", format="text", force=True)
    model.save(tmp_path / "m", format="bin")
    with pytest.raises(ValueError, match="format"):
        model.save(tmp_path / "x", format="json")
    with pytest.raises(TypeError, match="progress"):
        vpctl.sim.run_campaign(preset="quick", progress=42)
