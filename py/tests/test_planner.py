"""vpctl.planner: plans from Python equal plans from `vpctl plan`."""

import json

import numpy as np
import pytest

import vpctl
from conftest import run_cli

CAMERA = {"width": 1200, "height": 800, "focal_px": 1800.0}


@pytest.fixture(scope="module")
def planning(site, tmp_path_factory):
    """Site mesh, an initial grid flight as a COLMAP model, a small config
    (as TOML file and as dict) and the rock's box."""
    root = tmp_path_factory.mktemp("planner")
    site.save(root / "site.ply")
    lo, hi = site.rock_bounds
    c = (lo + hi) / 2
    footprint = [c[0] - 22, c[1] - 22, lo[2], c[0] + 22, c[1] + 22, hi[2]]
    fv = site.flight_volume
    cfg = {
        "n_triangles": 300,
        "n_surrogates": 600,
        "n_selected": 60,
        "n_triplets": 2,
        "flight_volume": fv.tolist(),
        "camera": CAMERA,
        # The model's cameras are the true ones and the vehicle flies
        # exactly: no position margin (standard GNSS's 12.8 m leaves no
        # position in this small flight volume), as the CLI tests' fixture.
        "safety": {"gnss": {"horizontal_m": 0.0, "vertical_m": 0.0}, "tracking_m": 0.0},
    }
    toml = "\n".join(
        [f"{k} = {v}" for k, v in cfg.items() if k not in ("flight_volume", "camera", "safety")]
        + [f"flight_volume = {fv.tolist()}", "[camera]"]
        + [f"{k} = {v}" for k, v in CAMERA.items()]
        + ["[safety]", "gnss = { horizontal_m = 0.0, vertical_m = 0.0 }", "tracking_m = 0.0"]
    )
    (root / "plan.toml").write_text(toml + "\n")
    initial = vpctl.planner.plan_grid(site.mesh, roi=footprint, height=50.0, overlap=0.8,
                                      initial=True, config={"camera": CAMERA})
    cams = vpctl.planner.plan_cameras(initial, config={"camera": CAMERA})
    named = [(f"img_{i + 1:03}.jpg", cam) for i, cam in enumerate(cams)]
    model = vpctl.labelgen.sparse_model(named, vpctl.scene.RayCaster(site.mesh), np.zeros((0, 3)))
    model.save(root / "model", format="text")
    return root, cfg, model, [*lo, *hi], cams


def test_plan_equals_cli_plan(planning, site, tmp_path):
    root, cfg, model, roi, _ = planning
    roi_arg = ",".join(str(x) for x in roi)
    run_cli("plan", "--mesh", root / "site.ply", "--colmap", root / "model", "--config", root / "plan.toml",
            "--roi-box", roi_arg, "--out", tmp_path / "cli.json", "--no-timings", "--frame-unchecked")
    # A model folder goes through the call `vpctl plan` makes: the same
    # frame check (refused here, as the CLI refuses it without the flag).
    with pytest.raises(ValueError, match="frame.json"):
        vpctl.planner.plan(root / "site.ply", root / "model", config=root / "plan.toml", roi=roi)
    r = vpctl.planner.plan(root / "site.ply", root / "model", config=root / "plan.toml", roi=roi,
                           frame_unchecked=True)
    r.plan.save(tmp_path / "py.json", no_timings=True)
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    assert r.plan.to_json(no_timings=True) + "\n" == (tmp_path / "cli.json").read_text()
    # The same config as a dict, the mesh and model as objects: the same plan.
    r2 = vpctl.planner.plan(site.mesh, model, config=cfg, roi=roi)
    assert r2.plan.to_json(no_timings=True) == r.plan.to_json(no_timings=True)


def test_plan_result_numbers(planning, site):
    root, cfg, model, roi, cams = planning
    r = vpctl.planner.plan(site.mesh, cams, config=cfg, roi=roi)
    plan = r.plan
    members = [w for w in plan.waypoints if w["role"] == "triplet_member"]
    flown = len(r.triplet_gains) - len(r.dropped_triplets)
    assert len(members) == 3 * flown and len(r.triplet_gains) <= 2
    assert all(0 <= t < len(r.triplet_gains) for t in r.dropped_triplets)
    assert len(r.dropped_reasons) == len(r.dropped_triplets)
    assert all(g > 0 for g in r.triplet_gains)
    pos = plan.positions
    assert pos.shape == (len(plan), 3) and plan.angles.shape == (len(plan), 2)
    its = r.iterations
    assert all(it["f_after"] >= it["f_before"] for it in its)
    s = r.sampled
    n = len(s["f"])
    assert 0 < n <= cfg["n_triangles"] and s["centroid"].shape == (n, 3)
    assert np.all((s["f"] >= 0) & (s["f"] <= 1))
    assert np.count_nonzero(s["selected"]) <= cfg["n_selected"]
    d = plan.to_dict()
    safety = d["safety_distance_m"]
    dist = vpctl.scene.Clearance(site.mesh).distance(pos)
    assert np.all(dist >= safety - 1e-6)
    lo, hi = np.array(cfg["flight_volume"])
    assert np.all((pos >= lo - 1e-9) & (pos <= hi + 1e-9))
    # Uniform confidence 1 is the NP variant: the same plan as no confidence.
    ones = [vpctl.forest.ConfidenceImage.constant(1.0)] * len(cams)
    r1 = vpctl.planner.plan(site.mesh, cams, confidence=ones, config=cfg, roi=roi)
    assert r1.plan.to_json(no_timings=True) == plan.to_json(no_timings=True)


def test_plan_file_round_trip(planning, site, tmp_path):
    g = vpctl.planner.plan_grid(site.mesh, height=50, overlap=0.5, origin=(46.0, 10.3, 400.0))
    g.save(tmp_path / "g.json")
    back = vpctl.planner.Plan.load(tmp_path / "g.json")
    assert back.to_json() == g.to_json()
    assert vpctl.planner.Plan.from_json(g.to_json()).to_dict() == json.loads(g.to_json())
    assert g.to_dict()["origin"] == {"lat_deg": 46.0, "lon_deg": 10.3, "alt_m": 400.0}
    assert all(w["role"] == "grid" for w in g.waypoints)
    with pytest.raises(FileExistsError):
        g.save(tmp_path / "g.json")


def test_grid_equals_cli(planning, tmp_path):
    root = planning[0]
    run_cli("plan", "grid", "--mesh", root / "site.ply", "--height", "50", "--overlap", "0.5",
            "--out", tmp_path / "cli.json")
    vpctl.planner.plan_grid(root / "site.ply", height=50, overlap=0.5).save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()


def test_config_defaults_and_bad_inputs(planning, site, tmp_path):
    root, cfg, model, roi, cams = planning
    d = vpctl.planner.default_config()
    assert d["n_triangles"] == 2000 and d["n_triplets"] == 4
    assert "n_triangles" in vpctl.planner.default_config_toml()
    with pytest.raises(ValueError):
        vpctl.planner.plan(site.mesh, cams, config={"n_triangles": 0})
    with pytest.raises(ValueError, match="no_such"):
        vpctl.planner.plan(site.mesh, cams, config={"no_such": 1})
    with pytest.raises(FileNotFoundError):
        vpctl.planner.plan(site.mesh, cams, config=tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="selects no face"):
        vpctl.planner.plan(site.mesh, cams, config=cfg, roi=[500, 500, 0, 501, 501, 1])
    with pytest.raises(ValueError):
        vpctl.planner.plan(site.mesh, cams, confidence=[None], config=cfg)
    with pytest.raises(FileNotFoundError, match=r"img_001\.jpg\.vpconf"):
        (tmp_path / "conf").mkdir()
        vpctl.planner.plan(site.mesh, model, confidence=tmp_path / "conf", config=cfg, roi=roi)
    with pytest.raises(ValueError):
        vpctl.planner.plan(site.mesh, 42)
    with pytest.raises(ValueError):
        vpctl.planner.plan_grid(site.mesh, origin=(100.0, 0.0, 0.0))


def _area_kml(path, lon0, lat0, half_m):
    """A Google Earth polygon: a square of 2 half_m metres around (lon0, lat0)."""
    import math

    dlon = half_m / (111_320.0 * math.cos(math.radians(lat0)))
    dlat = half_m / 110_540.0
    ring = [(lon0 - dlon, lat0 - dlat), (lon0 + dlon, lat0 - dlat), (lon0 + dlon, lat0 + dlat),
            (lon0 - dlon, lat0 + dlat), (lon0 - dlon, lat0 - dlat)]
    coords = " ".join(f"{lon:.10f},{lat:.10f},0" for lon, lat in ring)
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<kml xmlns="http://www.opengis.net/kml/2.2">'
        f"<Document><Placemark><name>Area</name><Polygon><outerBoundaryIs><LinearRing>"
        f"<coordinates>{coords}</coordinates></LinearRing></outerBoundaryIs></Polygon>"
        "</Placemark></Document></kml>\n"
    )


def test_plan_grid_roi_polygon_equals_cli(site, tmp_path):
    from conftest import run_cli

    mesh_path = tmp_path / "site.ply"
    site.save(mesh_path)
    lo, hi = site.rock_bounds
    cx, cy = (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2
    lat0 = 46.0 + cy / 110_540.0
    lon0 = 10.3 + cx / (111_320.0 * np.cos(np.radians(46.0)))
    area = tmp_path / "area.kml"
    _area_kml(area, lon0, lat0, 12.0)
    cli = tmp_path / "cli.json"
    run_cli("plan", "grid", "--mesh", mesh_path, "--origin", "46.0,10.3,400", "--height", "30",
            "--roi-polygon", area, "--out", cli)
    plan = vpctl.planner.plan_grid(mesh_path, height=30, origin=(46.0, 10.3, 400.0), roi_polygon=area)
    plan.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == cli.read_bytes()
    everything = vpctl.planner.plan_grid(mesh_path, height=30, origin=(46.0, 10.3, 400.0))
    assert len(plan) < len(everything)
    with pytest.raises(ValueError, match="area.kml"):
        vpctl.planner.plan_grid(mesh_path, height=30, roi_polygon=area)
    with pytest.raises(ValueError, match="not both"):
        vpctl.planner.plan_grid(mesh_path, roi=(0, 0, 0, 1, 1, 1), roi_polygon=area, origin=(46.0, 10.3, 400.0))


def _axis_angle(r):
    """The axis-angle vector of rotation matrix r, through its quaternion
    (stable at the half turns of nadir views)."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(r))) / 2
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if w > 1e-3:
        v = v / (4 * w)
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = np.sqrt(max(0.0, 1.0 + r[i, i] - r[j, j] - r[k, k])) * 2
        q = np.zeros(3)
        q[i] = s / 4
        q[j] = (r[j, i] + r[i, j]) / s
        q[k] = (r[k, i] + r[i, k]) / s
        w = (r[k, j] - r[j, k]) / s
        v = q if w >= 0 else -q
        w = abs(w)
    n = np.linalg.norm(v)
    return (2 * np.arctan2(n, w) * v / n).tolist() if n > 0 else [0.0, 0.0, 0.0]


def test_plan_on_an_opensfm_reconstruction_equals_cli_and_colmap(planning, tmp_path):
    """An OpenDroneMap project folder plans from Python as `vpctl plan
    --opensfm` does, and as the same cameras in a COLMAP model do."""
    root, _, _, roi, cams = planning
    shots = {}
    for i, cam in enumerate(cams):
        wfc = np.asarray(cam.world_from_cam)
        r_cw = wfc[:3, :3].T
        t = -r_cw @ wfc[:3, 3]
        shots[f"img_{i + 1:03}.jpg"] = {"camera": "cam", "rotation": _axis_angle(r_cw),
                                        "translation": t.tolist()}
    w, h = CAMERA["width"], CAMERA["height"]
    rec = [{"cameras": {"cam": {"projection_type": "perspective", "width": w, "height": h,
                                "focal": CAMERA["focal_px"] / max(w, h), "k1": 0.0, "k2": 0.0}},
            "shots": shots, "points": {}}]
    (tmp_path / "odm" / "opensfm").mkdir(parents=True)
    (tmp_path / "odm" / "opensfm" / "reconstruction.json").write_text(json.dumps(rec))
    roi_arg = ",".join(str(x) for x in roi)
    run_cli("plan", "--mesh", root / "site.ply", "--opensfm", tmp_path / "odm", "--config",
            root / "plan.toml", "--roi-box", roi_arg, "--out", tmp_path / "cli.json", "--no-timings",
            "--frame-unchecked")
    r = vpctl.planner.plan(root / "site.ply", tmp_path / "odm", config=root / "plan.toml", roi=roi,
                           frame_unchecked=True)
    assert r.plan.to_json(no_timings=True) + "\n" == (tmp_path / "cli.json").read_text()
    c = vpctl.planner.plan(root / "site.ply", root / "model", config=root / "plan.toml", roi=roi,
                           frame_unchecked=True)
    a = np.array([wp["position"] for wp in json.loads(r.plan.to_json())["waypoints"]])
    b = np.array([wp["position"] for wp in json.loads(c.plan.to_json())["waypoints"]])
    assert a.shape == b.shape
    assert np.abs(a - b).max() < 1e-6
    # Without a reference the frame check says how to get one.
    with pytest.raises(ValueError, match="no geodetic reference"):
        vpctl.planner.plan(root / "site.ply", tmp_path / "odm", config=root / "plan.toml", roi=roi)
