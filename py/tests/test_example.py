"""py/examples/notebook.py runs end to end and writes what it promises."""

import json
import subprocess
import sys
from pathlib import Path

import vpctl

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "notebook.py"


def test_notebook_example_writes_model_plan_and_mission(tmp_path):
    p = subprocess.run([sys.executable, str(EXAMPLE), "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    forest = vpctl.forest.Forest.load(tmp_path / "tiny.vpforest")
    assert forest.n_trees == 3
    plan = vpctl.planner.Plan.load(tmp_path / "plan.json")
    members = [w for w in plan.waypoints if w["role"] == "triplet_member"]
    assert len(members) in (3, 6)
    qgc = json.loads((tmp_path / "mission.plan").read_text())
    assert qgc["fileType"] == "Plan"
    assert "verified: True" in p.stdout
