"""vpctl.labelgen: triplet sampling and labels, against the CLI."""

import math

import numpy as np
import pytest

import vpctl
from conftest import files_under, heightfield, run_cli

K = (96, 72, 60.0)


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    """A heightfield with a box, 4 triplets of cameras at 4 angles, their
    exact depth maps (level 1), the sparse model and the triplet list."""
    root = tmp_path_factory.mktemp("labelgen")
    mesh = heightfield()
    caster = vpctl.scene.RayCaster(mesh)
    cams, triplets = [], []
    for t, angle in enumerate([8.0, 15.0, 25.0, 35.0]):
        cx, cy = -8.0 + 16.0 * (t % 2), -8.0 + 16.0 * (t // 2)
        r = 2.0 * 32.0 * math.tan(math.radians(0.5 * angle)) / math.sqrt(3.0)
        names = []
        for i in range(3):
            a = 0.4 * t + i * 2.0 * math.pi / 3.0
            c = [cx + r * math.cos(a), cy + r * math.sin(a), 32.0]
            name = f"img{t}{i}.jpg"
            cams.append((name, vpctl.scene.Camera.look_at(*K, c, [cx, cy, 0.0])))
            names.append(name)
        triplets.append({"bin": 0, "angle_deg": angle, "images": names})
    model = vpctl.labelgen.sparse_model(cams, caster, mesh.vertices[::3])
    model.save(root / "model", format="text")
    mesh.save(root / "mesh.ply")
    vpctl.labelgen.write_triplet_list(root / "triplets.txt", triplets)
    by_name = dict(cams)
    for t, tr in enumerate(triplets):
        for name in tr["images"]:
            depth, _ = caster.render_depth(by_name[name])
            path = vpctl.labelgen.depth_map_path(root / "depth", vpctl.labelgen.triplet_id(t), 1, name)
            path.parent.mkdir(parents=True, exist_ok=True)
            vpctl.scene.write_depth_map(path, depth)
    return root, mesh, model, triplets, cams


def test_triplet_list_round_trip(scene_files):
    root, _, _, triplets, _ = scene_files
    back = vpctl.labelgen.read_triplet_list(root / "triplets.txt")
    assert [t["images"] for t in back] == [t["images"] for t in triplets]
    assert [t["angle_deg"] for t in back] == pytest.approx([t["angle_deg"] for t in triplets])
    assert vpctl.labelgen.triplet_id(3) == "t0003"


def test_sample_triplets_equals_cli(scene_files, tmp_path):
    root, _, model, _, _ = scene_files
    run_cli("labelgen", "triplets", "--colmap", root / "model", "--per-bin", "3", "--seed", "4",
            "--out", tmp_path / "cli.txt")
    t = vpctl.labelgen.sample_triplets(model, per_bin=3, seed=4)
    assert len(t) > 0
    assert all(len(set(x["images"])) == 3 and 4.0 <= x["angle_deg"] < 128.0 for x in t)
    vpctl.labelgen.write_triplet_list(tmp_path / "py.txt", t)
    assert (tmp_path / "py.txt").read_bytes() == (tmp_path / "cli.txt").read_bytes()
    assert vpctl.labelgen.sample_triplets(model, per_bin=3, seed=4) == t
    with pytest.raises(FileExistsError):
        vpctl.labelgen.write_triplet_list(tmp_path / "py.txt", t)


def test_labels_equal_cli_run(scene_files, tmp_path):
    root, mesh, model, triplets, _ = scene_files
    run_cli("labelgen", "run", "--colmap", root / "model", "--triplets", root / "triplets.txt",
            "--depth-dir", root / "depth", "--mesh", root / "mesh.ply", "--out", tmp_path / "cli",
            "--frame-unchecked")
    recs = vpctl.labelgen.load_reconstructions(model, triplets, root / "depth")
    assert [r.id for r in recs] == [f"t{t:04}/level1" for t in range(4)]
    labels = vpctl.labelgen.generate_labels(recs, mesh=vpctl.scene.Mesh.load(root / "mesh.ply"))
    summary = labels.write(tmp_path / "py")
    assert files_under(tmp_path / "py") == files_under(tmp_path / "cli")
    assert len(labels) == 4
    first = labels[0]
    assert first["names"] == triplets[0]["images"]
    lab, ang = first["labels"][0]
    assert lab.shape == (72, 96) and ang.shape == (72, 96)
    counts = first["counts"][0]
    assert np.count_nonzero(lab == 1) == counts["positive"]
    assert np.count_nonzero(lab == 2) == counts["negative_voted"] + counts["negative_missing"]
    assert np.all(np.isfinite(ang[lab > 0])) and np.all(np.isnan(ang[lab == 0]))
    assert summary["positive"] > 0 and 0.0 < summary["labelled_share"] <= 1.0
    assert labels.summary() == summary


def test_run_writes_the_cli_label_folder_byte_for_byte(scene_files, tmp_path):
    """vpctl.labelgen.run is the front door `vpctl labelgen run` calls: the
    same inputs give the same label files and summary, and the same refusals
    (an earlier output without force, a folder vpctl did not write)."""
    root = scene_files[0]
    args = dict(triplets=root / "triplets.txt", depth_dir=root / "depth",
                mesh=root / "mesh.ply", frame_unchecked=True)
    (tmp_path / "lg.toml").write_text("min_support = 2\n")
    run_cli("labelgen", "run", "--colmap", root / "model", "--triplets", args["triplets"],
            "--depth-dir", args["depth_dir"], "--mesh", args["mesh"], "--out", tmp_path / "cli",
            "--frame-unchecked", "--config", tmp_path / "lg.toml")
    summary = vpctl.labelgen.run(root / "model", out=tmp_path / "py",
                                 params={"min_support": 2}, **args)
    got, want = files_under(tmp_path / "py"), files_under(tmp_path / "cli")
    assert got.keys() == want.keys()
    assert sum(k.endswith(".vplabel") for k in got) == 4 * 3
    for rel in want:
        assert got[rel] == want[rel], rel
    assert summary["reconstructions"] == 4 and summary["positive"] > 0
    with pytest.raises(ValueError, match="earlier `vpctl labelgen run`"):
        vpctl.labelgen.run(root / "model", out=tmp_path / "py", **args)
    vpctl.labelgen.run(root / "model", out=tmp_path / "py", force=True, **args)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine/notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="mine"):
        vpctl.labelgen.run(root / "model", out=tmp_path / "mine", **args)
    # Without --frame-unchecked the model's frame.json is required, as in the CLI.
    with pytest.raises((ValueError, FileNotFoundError), match="frame"):
        vpctl.labelgen.run(root / "model", out=tmp_path / "f", triplets=args["triplets"],
                           depth_dir=args["depth_dir"])
    assert not (tmp_path / "f").exists()


def test_reconstructions_from_numpy_and_bad_inputs(scene_files):
    root, _, _, triplets, cams = scene_files
    by_name = dict(cams)
    caster = vpctl.scene.RayCaster(heightfield())
    views = [(n, by_name[n], caster.render_depth(by_name[n])[0]) for n in triplets[0]["images"]]
    rec = vpctl.labelgen.TripletReconstruction("a", views)
    assert rec.names == triplets[0]["images"]
    other = vpctl.labelgen.TripletReconstruction(
        "b", [(n, by_name[n], caster.render_depth(by_name[n])[0]) for n in triplets[1]["images"]])
    labels = vpctl.labelgen.generate_labels([rec, other], params={"min_support": 1})
    assert len(labels) == 2 and labels[1]["id"] == "b"
    with pytest.raises(IndexError):
        labels[2]
    with pytest.raises(ValueError, match="3"):
        vpctl.labelgen.TripletReconstruction("c", views[:2])
    bad = views[0][2].copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError):
        vpctl.labelgen.TripletReconstruction("d", [(views[0][0], views[0][1], bad)] + views[1:])
    with pytest.raises(ValueError, match="twice"):
        vpctl.labelgen.generate_labels([rec, rec])
    with pytest.raises(ValueError):
        vpctl.labelgen.generate_labels([rec], params={"s_min": -1})
    with pytest.raises(FileNotFoundError):
        vpctl.labelgen.load_reconstructions(
            vpctl.scene.ColmapModel.load(root / "model"), triplets, root / "no_depth")
