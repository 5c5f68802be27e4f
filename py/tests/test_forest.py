"""vpctl.forest: training, prediction, model files, metrics."""

import numpy as np
import pytest

import vpctl
from conftest import run_cli

TINY = {
    "n_trees": 3,
    "max_depth": 8,
    "min_samples_split": 10,
    "n_tests": 60,
    "n_thresholds": 10,
    "n_node_samples": 200,
    "samples_per_class": 4000,
}


def texture(seed: int, size: int = 96, block: int = 16):
    """Blocks that are smooth (positive: the MVS works) or noisy (negative),
    each with its own colour, so that only texture tells them apart."""
    rng = np.random.default_rng(seed)
    nb = size // block
    noisy_blocks = rng.random((nb, nb)) < 0.5
    colours = rng.uniform(60, 196, (nb, nb, 3))
    noisy = np.kron(noisy_blocks, np.ones((block, block), dtype=bool))
    base = np.kron(colours, np.ones((block, block, 1)))
    yy, xx = np.mgrid[0:size, 0:size]
    smooth = base + (20 * np.sin(0.11 * xx + 0.07 * yy))[..., None]
    rough = base + rng.uniform(-60, 60, (size, size, 3))
    img = np.where(noisy[..., None], rough, smooth).clip(0, 255).astype(np.uint8)
    labels = np.where(noisy, 2, 1).astype(np.uint8)
    # Keep pixels away from block borders, where the patch sees both kinds.
    r = np.minimum(xx % block, block - 1 - xx % block)
    r = np.minimum(r, np.minimum(yy % block, block - 1 - yy % block))
    labels[r < 3] = 0
    angles = rng.uniform(0, 45, (size, size)).astype(np.float32)
    angles[labels == 0] = np.nan
    return img, labels, angles


@pytest.fixture(scope="module")
def forest():
    data = [texture(s) for s in (1, 2)]
    return vpctl.forest.train(
        [d[0] for d in data], [d[1] for d in data], [d[2] for d in data], params=TINY, seed=7
    )


def test_train_summary_and_determinism(forest):
    assert forest.n_trees == 3
    assert forest.params["max_depth"] == 8
    s = forest.summary
    assert s["n_images"] == 2 and s["seed"] == 7
    assert s["n_positive"] > 0 and s["n_negative"] > 0
    data = [texture(s) for s in (1, 2)]
    again = vpctl.forest.train([d[0] for d in data], [d[1] for d in data], [d[2] for d in data], params=TINY, seed=7)
    assert again.to_bytes() == forest.to_bytes()


def test_predict_shape_range_and_accuracy_on_held_out(forest):
    img, labels, angles = texture(9)
    conf = forest.predict(img, step=8)
    v = conf.values
    assert v.shape == (12, 12, 9) and v.dtype == np.float32
    assert np.all((v >= 0) & (v <= 1))
    assert conf.step == 8 and conf.size == (96, 96)
    assert conf.bin_edges == pytest.approx([5.0 * i for i in range(10)])
    c, pos = forest.score(img, labels, angles)
    assert len(c) == np.count_nonzero(labels) and pos.sum() == np.count_nonzero(labels == 1)
    assert vpctl.forest.accuracy(c, pos) > 0.8
    sp = vpctl.forest.sparsification(c, pos, curve_points=20)
    assert sp["relative_ausc"] < sp["random_relative_ausc"]
    # Sampling at a grid node reads the node's values (angle at a bin centre).
    x, y = 8 * 3 + 4 + 0.5, 8 * 5 + 4 + 0.5
    got = conf.sample(np.array([[x, y]]), np.array([12.5]))
    assert got[0] == pytest.approx(v[5, 3, 2], abs=1e-6)


def test_save_load_round_trip_and_errors(tmp_path, forest):
    p = tmp_path / "f.vpforest"
    forest.save(p)
    assert p.read_bytes() == forest.to_bytes()
    assert vpctl.forest.Forest.load(p).to_bytes() == forest.to_bytes()
    with pytest.raises(FileExistsError):
        forest.save(p)
    with pytest.raises(FileNotFoundError):
        vpctl.forest.Forest.load(tmp_path / "missing")
    (tmp_path / "junk").write_bytes(b"not a model")
    with pytest.raises(ValueError, match="junk"):
        vpctl.forest.Forest.load(tmp_path / "junk")
    img, _, _ = texture(3)
    conf = forest.predict(img)
    conf.save(tmp_path / "c.vpconf")
    back = vpctl.forest.ConfidenceImage.load(tmp_path / "c.vpconf")
    assert np.array_equal(back.values, conf.values)


def test_confidence_image_from_numpy():
    vals = np.linspace(0, 1, 4 * 5 * 9, dtype=np.float32).reshape(4, 5, 9)
    c = vpctl.forest.ConfidenceImage(vals, 40, 32, 8)
    assert np.array_equal(c.values, vals)
    assert vpctl.forest.ConfidenceImage.constant(1.0).values.max() == 1.0
    with pytest.raises(ValueError, match="grid"):
        vpctl.forest.ConfidenceImage(vals, 400, 32, 8)


def test_bad_training_inputs():
    img, labels, angles = texture(1)
    with pytest.raises(ValueError, match="one of each"):
        vpctl.forest.train([img], [labels, labels], [angles])
    bad = labels.copy()
    bad[10, 10] = 7
    with pytest.raises(ValueError, match="label 7"):
        vpctl.forest.train([img], [bad], [angles], params=TINY)
    with pytest.raises(ValueError, match="differ in shape"):
        vpctl.forest.train([img], [labels], [angles[:10]], params=TINY)
    with pytest.raises(ValueError, match="both classes"):
        vpctl.forest.train([img], [np.where(labels > 0, 1, 0).astype(np.uint8)], [angles], params=TINY)
    with pytest.raises(ValueError):
        vpctl.forest.train([img], [labels], [angles], params={"n_trees": 0})
    with pytest.raises(ValueError):
        vpctl.forest.train([img], [labels], [angles], params={"no_such": 1})
    with pytest.raises(ValueError):
        vpctl.forest.train([img[..., :2]], [labels], [angles], params=TINY)


def test_forest_takes_array_likes_of_any_real_dtype(forest):
    """Issue 40: `Forest.predict` on a float image raised "type mismatch:
    from=float64, to=uint8" naming neither the argument nor what it wants.
    A real image is in [0, 1] (scikit-image's convention), integers in 0..255."""
    img, labels, angles = texture(9)
    ref = forest.predict(img, step=8).values
    for same in [img / 255.0, (img / 255.0).astype(np.float32), img.astype(np.int64),
                 np.asfortranarray(img), img.tolist()]:
        assert np.array_equal(forest.predict(same, step=8).values, ref)
    c, pos = forest.score(img, labels, angles)
    c2, pos2 = forest.score(img / 255.0, labels.astype(np.int32), angles.astype(np.float64))
    assert np.array_equal(c, c2) and np.array_equal(pos, pos2)
    assert vpctl.forest.accuracy(c.tolist(), pos.tolist()) == vpctl.forest.accuracy(c, pos)
    with pytest.raises(ValueError, match=r"image: expected a \(H, W, 3\) image of integers in 0..=255 or reals "
                       r"in \[0, 1\] \(uint8\): values from 2 to 243 \(reals are scaled by 255"):
        forest.predict(img.astype(np.float64))
    with pytest.raises(ValueError, match=r"image: expected a \(H, W, 3\) .*got shape \(96, 96\)"):
        forest.predict(img[..., 0])
    with pytest.raises(TypeError, match=r"labels: expected a \(H, W\) array of integers in 0..=255 \(uint8\), got dtype float64"):
        forest.score(img, labels.astype(np.float64), angles)
    with pytest.raises(TypeError, match=r"positive: expected an \(N,\) array of booleans \(bool\), got dtype int64"):
        vpctl.forest.accuracy(c, pos.astype(np.int64))
    vals = np.linspace(0, 1, 4 * 5 * 9).reshape(4, 5, 9)
    conf = vpctl.forest.ConfidenceImage(vals, 40, 32, 8)
    assert np.array_equal(conf.values, vals.astype(np.float32))
    assert conf.sample([[4.5, 4.5]], [2.5])[0] == pytest.approx(vals[0, 0, 0], abs=1e-6)


def test_metrics_exact_values():
    c = np.array([0.9, 0.8, 0.3, 0.1], dtype=np.float32)
    pos = np.array([True, False, False, True])
    assert vpctl.forest.accuracy(c, pos, 0.5) == pytest.approx(0.5)
    perfect = vpctl.forest.sparsification(np.array([0.9, 0.2], dtype=np.float32), np.array([True, False]))
    assert perfect["relative_ausc"] == pytest.approx(1.0)
    with pytest.raises(ValueError):
        vpctl.forest.accuracy(c, pos[:2])
    assert (vpctl.forest.default_params()["n_trees"], vpctl.forest.default_params()["max_depth"]) == (10, 16)
    assert vpctl.forest.default_params("paper")["n_trees"] == 20
    with pytest.raises(ValueError, match="paper"):
        vpctl.forest.default_params("papr")


def test_train_and_predict_equal_cli(tmp_path):
    images, labels = tmp_path / "images", tmp_path / "labels"
    images.mkdir()
    for s in (1, 2):
        img, lab, ang = texture(s)
        vpctl.scene.save_image(images / f"img{s}.png", img)
        (labels / f"t{s}").mkdir(parents=True)
        vpctl.scene.write_label_image(labels / f"t{s}" / f"img{s}.png.vplabel", lab, ang)
        back_l, back_a = vpctl.scene.read_label_image(labels / f"t{s}" / f"img{s}.png.vplabel")
        assert np.array_equal(back_l, lab) and np.array_equal(np.isnan(back_a), np.isnan(ang))
        assert np.array_equal(vpctl.scene.load_image(images / f"img{s}.png"), img)
    (tmp_path / "params.toml").write_text("".join(f"{k} = {v}\n" for k, v in TINY.items()))
    run_cli("train", "--images", images, "--labels", labels, "--config", tmp_path / "params.toml",
            "--seed", "7", "--out", tmp_path / "cli.vpforest")
    forest = vpctl.forest.train_dirs(images, labels, params=TINY, seed=7)
    assert forest.to_bytes() == (tmp_path / "cli.vpforest").read_bytes()
    run_cli("predict", "--forest", tmp_path / "cli.vpforest", "--out", tmp_path / "cli_conf", "--no-previews",
            images / "img1.png")
    forest.predict(vpctl.scene.load_image(images / "img1.png")).save(tmp_path / "py.vpconf")
    assert (tmp_path / "py.vpconf").read_bytes() == (tmp_path / "cli_conf" / "img1.png.vpconf").read_bytes()
    with pytest.raises(ValueError, match="no .vplabel"):
        vpctl.forest.train_dirs(images, images, params=TINY)
