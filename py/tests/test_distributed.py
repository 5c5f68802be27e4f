"""vpctl.distributed on a LocalCluster of 2 workers: the same depth maps,
labels and model bytes as the CLI on one machine, also when a worker is
killed mid-run; clear errors for an unreachable scheduler, missing files
and a worker without vpctl."""

import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import vpctl
from conftest import files_under, heightfield, run_cli

distributed = pytest.importorskip("distributed", reason="pip install './py[dask]'")
vd = pytest.importorskip("vpctl.distributed")

K = (96, 72, 60.0)
MVS_TOML = "iterations = 2\n"
FOREST = dict(n_trees=4, max_depth=8, min_samples_split=10, n_tests=300, n_thresholds=20,
              n_node_samples=300, samples_per_class=20000, balance_classes=False)
FOREST_TOML = "".join(f"{k} = {str(v).lower() if isinstance(v, bool) else v}\n" for k, v in FOREST.items())


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A site directory (vpctl.distributed.site_layout): a rendered
    heightfield with a box seen by 4 triplets of 96x72 cameras."""
    root = tmp_path_factory.mktemp("site")
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
            name = f"img{t}{i}.png"
            cams.append((name, vpctl.scene.Camera.look_at(*K, c, [cx, cy, 0.0])))
            names.append(name)
        triplets.append({"bin": 0, "angle_deg": angle, "images": names})
    s = vd.site_layout(root)
    s["images"].mkdir(parents=True)
    for name, cam in cams:
        vpctl.scene.save_image(s["images"] / name, vpctl.sim.render(mesh, caster, cam)["rgb"])
    model = vpctl.labelgen.sparse_model(cams, caster, mesh.vertices[::3])
    model.save(s["model"], format="text")
    mesh.save(s["mesh"])
    vpctl.labelgen.write_triplet_list(s["triplets"], triplets)
    s["mvs_config"].write_text(MVS_TOML)
    s["forest_config"].write_text(FOREST_TOML)
    return root


@pytest.fixture(scope="module")
def cli(site, tmp_path_factory):
    """The one-machine results of the CLI: depth maps, labels, model."""
    out = tmp_path_factory.mktemp("cli")
    s = vd.site_layout(site)
    run_cli("mvs", "run", "--workspace", s["dense"], "--triplets", s["triplets"], "--levels", "1,2",
            "--out", out / "depth", "--config", s["mvs_config"])
    run_cli("labelgen", "run", "--model", s["model"], "--triplets", s["triplets"],
            "--depth-dir", out / "depth", "--mesh", s["mesh"], "--out-dir", out / "labels",
            "--frame-unchecked")
    run_cli("train", "--images", s["images"], "--labels", out / "labels", "--out",
            out / "model.vpforest", "--config", s["forest_config"], "--seed", "3")
    return out


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0", env={"RAYON_NUM_THREADS": "1"}) as c:
        with distributed.Client(c) as client:
            yield c, client


def no_partial_files(root: Path):
    leftovers = [p for p in root.rglob("*") if vd.STAGING in p.parts or ".tmp-" in p.name]
    assert not leftovers, leftovers


def test_pipeline_equals_the_cli(site, cli, cluster, tmp_path):
    _, client = cluster
    s = vd.site_layout(site)
    shares = vd.reconstruct_triplets(s["dense"], s["triplets"], [1, 2], tmp_path / "depth",
                                     client=client, params={"iterations": 2})
    assert sorted(shares) == [f"t000{t}/level{lv}" for t in range(4) for lv in (1, 2)]
    assert files_under(tmp_path / "depth") == files_under(cli / "depth")

    summary = vd.generate_labels(s["model"], s["triplets"], tmp_path / "depth", tmp_path / "labels",
                                 client=client, mesh=s["mesh"], frame_unchecked=True, chunk_size=3)
    assert summary["positive"] > 0 and summary["reconstructions"] == 8
    assert files_under(tmp_path / "labels") == files_under(cli / "labels")

    forest = vd.train_forest(s["images"], tmp_path / "labels", FOREST, seed=3, client=client,
                             out=tmp_path / "model.vpforest")
    assert (tmp_path / "model.vpforest").read_bytes() == (cli / "model.vpforest").read_bytes()
    assert forest.to_bytes() == (cli / "model.vpforest").read_bytes()
    with pytest.raises(FileExistsError):
        vd.train_forest(s["images"], tmp_path / "labels", FOREST, seed=3, client=client,
                        out=tmp_path / "model.vpforest")

    conf = vd.predict(tmp_path / "model.vpforest", [s["images"]], tmp_path / "conf", client=client,
                      chunk_size=5)
    run_cli("predict", "--model", cli / "model.vpforest", "--out", cli / "conf", s["images"])
    assert len([p for p in conf if p.suffix == ".vpconf"]) == 12
    assert files_under(tmp_path / "conf") == files_under(cli / "conf")
    no_partial_files(tmp_path)


def test_console_script_on_a_scheduler_address(site, cli, cluster, tmp_path):
    c, _ = cluster
    # A copy of the site whose depth/labels are written afresh.
    import shutil
    work = tmp_path / "site"
    shutil.copytree(site, work)
    exe = Path(sys.executable).with_name("vpctl-dask")
    p = subprocess.run([str(exe), "train", "--workspace", str(work), "--out", str(tmp_path / "m.vpforest"),
                        "--scheduler", c.scheduler_address, "--levels", "1,2", "--seed", "3",
                        "--frame-unchecked"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "m.vpforest").read_bytes() == (cli / "model.vpforest").read_bytes()
    assert "written:" in p.stdout
    no_partial_files(work)


def kill_a_busy_worker(client, prefix: str, timeout: float = 60.0):
    """Waits until a task whose key starts with `prefix` runs, then kills
    its worker process (SIGKILL: no cleanup). Returns the killed address."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        busy = {w: ks for w, ks in client.processing().items()
                if any(str(k).startswith(prefix) for k in ks)}
        if busy:
            worker = sorted(busy)[0]
            pid = client.run(os.getpid, workers=[worker])[worker]
            time.sleep(0.3)  # into the task
            os.kill(pid, signal.SIGKILL)
            return worker
        time.sleep(0.05)
    raise AssertionError(f"no {prefix} task started within {timeout} s")


def run_killing_one_worker(client, prefix, fn):
    result, error = {}, {}

    def target():
        try:
            result["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - re-raised in the test thread
            error["e"] = e

    t = threading.Thread(target=target)
    t.start()
    killed = kill_a_busy_worker(client, prefix)
    t.join(timeout=300)
    assert not t.is_alive(), "the run did not finish after a worker was killed"
    if error:
        raise error["e"]
    return killed, result["value"]


def test_a_worker_killed_mid_run_leaves_the_same_results(site, cli, cluster, tmp_path):
    c, client = cluster
    s = vd.site_layout(site)
    # Trees big enough to be killed in: a few seconds each in the dev build.
    params = dict(FOREST, n_trees=4, n_tests=1500, max_depth=12)
    killed, forest = run_killing_one_worker(
        client, "vpctl-tree",
        lambda: vd.train_forest(s["images"], cli / "labels", params, seed=5, client=client,
                                out=tmp_path / "model.vpforest"))
    single = vpctl.forest.train_dirs(s["images"], cli / "labels", params, seed=5)
    assert forest.to_bytes() == single.to_bytes()
    assert (tmp_path / "model.vpforest").read_bytes() == single.to_bytes()
    assert killed not in client.scheduler_info(n_workers=-1)["workers"]

    # The nanny restarts the killed worker (slow on a loaded machine).
    client.wait_for_workers(2, timeout=180)
    killed, shares = run_killing_one_worker(
        client, "vpctl-mvs",
        lambda: vd.reconstruct_triplets(s["dense"], s["triplets"], [1, 2], tmp_path / "depth",
                                        client=client, params={"iterations": 2}))
    assert len(shares) == 8
    assert files_under(tmp_path / "depth") == files_under(cli / "depth")
    assert killed not in client.scheduler_info(n_workers=-1)["workers"]
    no_partial_files(tmp_path)


def test_unreachable_scheduler_is_a_clear_error_within_the_timeout(site, monkeypatch):
    monkeypatch.setattr(vd, "CONNECT_TIMEOUT", 2.0)
    s = vd.site_layout(site)
    start = time.monotonic()
    with pytest.raises(ConnectionError, match=r"tcp://127\.0\.0\.1:9.*within 2 s"):
        vd.train_forest(s["images"], s["images"], FOREST, client="tcp://127.0.0.1:9")
    assert time.monotonic() - start < 15


def test_missing_files_are_named_before_any_task(site, tmp_path):
    s = vd.site_layout(site)
    with pytest.raises(FileNotFoundError, match="nolabels"):
        vd.train_forest(s["images"], tmp_path / "nolabels", FOREST, client="tcp://127.0.0.1:9")
    bad = [{"bin": 0, "angle_deg": 8.0, "images": ["img00.png", "ghost.png", "img02.png"]}]
    with pytest.raises(FileNotFoundError, match="ghost.png"):
        vd.reconstruct_triplets(s["dense"], bad, [1], tmp_path / "d", client="tcp://127.0.0.1:9")
    with pytest.raises(FileNotFoundError, match="nomodel"):
        vd.generate_labels(tmp_path / "nomodel", s["triplets"], tmp_path, tmp_path / "l",
                           client="tcp://127.0.0.1:9")
    with pytest.raises(FileNotFoundError, match="missing.vpforest"):
        vd.predict(tmp_path / "missing.vpforest", [s["images"]], tmp_path / "c",
                   client="tcp://127.0.0.1:9")
    assert not (tmp_path / "d").exists()


def test_a_worker_without_vpctl_is_named(site):
    s = vd.site_layout(site)
    # A worker process where `import vpctl` fails as if it were not installed.
    code = ("import sys; sys.modules['vpctl'] = None; "
            "from distributed.cli.dask_worker import main; sys.exit(main())")
    with distributed.LocalCluster(n_workers=0, dashboard_address=":0") as c:
        w = subprocess.Popen([sys.executable, "-c", code, c.scheduler_address, "--no-nanny",
                              "--nthreads", "1", "--name", "novpctl", "--no-dashboard"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(c) as client:
                client.wait_for_workers(1, timeout=60)
                with pytest.raises(RuntimeError, match=r"without the vpctl package.*missing") as e:
                    vd.train_forest(s["images"], s["images"], FOREST, client=client)
                assert "pip install 'vpctl[dask]'" in str(e.value)
                print(e.value)
        finally:
            w.kill()
            w.wait()


def test_a_patch_store_trains_the_cli_model_chunk_by_chunk(site, cli, cluster, tmp_path):
    """`vpctl-dask store` then `vpctl-dask train --store`: the model bytes of
    `vpctl train` on the same labels and seed, every tree streaming the
    store (a budget of 0 MiB loads no subtree); a missing store is exit 2
    naming it and the command that writes one, with nothing written."""
    c, client = cluster
    s = vd.site_layout(site)
    exe = str(Path(sys.executable).with_name("vpctl-dask"))
    store = tmp_path / "store"
    p = subprocess.run([exe, "store", "--images", str(s["images"]), "--labels", str(cli / "labels"),
                        "--out", str(store), "--params", str(s["forest_config"]), "--seed", "3",
                        "--chunk-len", "500"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "next: vpctl-dask train --store" in p.stdout
    p = subprocess.run([exe, "train", "--store", str(store), "--out", str(tmp_path / "m.vpforest"),
                        "--params", str(s["forest_config"]), "--scheduler", c.scheduler_address,
                        "--budget-mb", "0"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "m.vpforest").read_bytes() == (cli / "model.vpforest").read_bytes()

    forest = vd.train_forest_from_store(store, FOREST, client=client)
    assert forest.to_bytes() == (cli / "model.vpforest").read_bytes()
    with pytest.raises(ValueError, match="samples_per_class"):
        vd.train_forest_from_store(store, dict(FOREST, samples_per_class=5), client=client)

    p = subprocess.run([exe, "train", "--store", str(tmp_path / "nowhere"), "--out",
                        str(tmp_path / "x.vpforest")], capture_output=True, text=True, timeout=300)
    assert p.returncode == 2
    assert "nowhere" in p.stderr and "vpctl-dask store" in p.stderr
    assert not (tmp_path / "x.vpforest").exists()
    no_partial_files(tmp_path)
