"""``femupdate plan``: the command, its JSON, and the universal file re-read with pyuff."""

from __future__ import annotations

import json

import numpy as np
import pytest
import pyuff

from femupdate.cli import main
from femupdate.examples import portal_frame
from femupdate.io.plan_uff import write_plan_uff
from femupdate.io.uff.systems import read_2420
from femupdate.planning import PlanResult, plan
from femupdate import schema

CHAIN = """
[model]
name = "three-dof chain"
""" + "".join(f"""
[parameters.k{i}]
value = {v}
bounds = [{v / 4}, {v * 4}]
""" for i, v in ((1, 1000.0), (2, 1800.0), (3, 1500.0))) + "".join(f"""
[[element]]
type = "spring"
dofs = [{'"1:x"' if i == 1 else f'"{i - 1}:x", "{i}:x"'}]
k = "k{i}"

[[element]]
type = "mass"
dofs = ["{i}:x"]
m = {m}
""" for i, m in ((1, 1.0), (2, 1.2), (3, 0.8)))


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out, err


@pytest.fixture
def chain_file(tmp_path):
    p = tmp_path / "chain.toml"
    p.write_text(CHAIN)
    return p


def test_plan_command_writes_json_and_universal_file(chain_file, tmp_path, capsys):
    out_json, out_uff = tmp_path / "plan.json", tmp_path / "plan.uff"
    code, out, err = run(["plan", str(chain_file), "--modes", "2", "--points", "3", "--json", str(out_json),
                          "--uff", str(out_uff)], capsys)
    assert code == 0, err
    assert "expected verdict: unique" in out
    obj = json.loads(out_json.read_text())
    schema.check(obj, "plan")
    assert obj["kind"] == "plan" and obj["uniqueness"]["layout_rank_bound"] == 3
    assert len(obj["dofs"]) == 2  # m n >= 3 with n > 1: two sensors for two modes
    res = PlanResult.from_json(out_json)
    assert res.sensors == obj["sensors"]
    sets = pyuff.UFF(str(out_uff)).read_sets()
    assert [d["type"] for d in sets] == [164, 2420, 15, 2411, 82]
    nodes = [int(d.split(":")[0]) for d in obj["dofs"]]
    assert [int(v) for v in sets[2]["node_nums"]] == nodes
    assert [int(v) for v in sets[3]["node_nums"]] == nodes
    assert [int(v) for v in sets[4]["nodes"]] == nodes


def test_universal_file_carries_the_sensor_directions(tmp_path):
    model = portal_frame()
    res = plan(model, n_modes=4, n_sensors=3, points=2, compare=False)
    path = tmp_path / "frame.uff"
    write_plan_uff(path, res)
    sets = pyuff.UFF(str(path)).read_sets()
    ds2420, ds15 = sets[1], sets[2]
    systems: dict = {}
    read_2420(ds2420, "frame.uff", systems)  # femupdate's own reader accepts the systems
    for (node, direction), x, y in zip([d.split(":") for d in res.dofs], ds15["x"], ds15["y"]):
        assert [x, y, 0.0] == pytest.approx(res.nodes[node])
        axis = systems[int(node)].R[0]  # local +x in global axes: the measuring direction
        assert axis == pytest.approx(np.eye(3)["xyz".index(direction)])
    assert [int(v) for v in ds15["disp_cs"]] == [int(d.split(":")[0]) for d in res.dofs]


def test_universal_file_2411_holds_the_coordinates_in_double_precision_and_the_exciters(tmp_path):
    model = portal_frame(n_per_member=3)  # beam nodes at 4/3 m: not a single-precision number
    res = plan(model, n_modes=3, n_sensors=3, fixed=["5:y"], points=1, compare=False, n_exciters=1, tam="none")
    path = tmp_path / "frame.uff"
    info = write_plan_uff(path, res)
    sets = pyuff.UFF(str(path)).read_sets()
    assert [d["type"] for d in sets] == info["datasets"] == [164, 2420, 15, 2411, 82]
    ds15, ds2411 = sets[2], sets[3]
    sensor_nodes = [int(d.split(":")[0]) for d in res.dofs]
    ex_node = int(res.exciters["dofs"][0].split(":")[0])
    assert [int(v) for v in ds2411["node_nums"]] == sensor_nodes + ([ex_node] if ex_node not in sensor_nodes else [])
    for n, x, y, z in zip(ds2411["node_nums"], ds2411["x"], ds2411["y"], ds2411["z"]):
        assert [x, y, z] == list(model.nodes[int(n)])  # to the last digit
    assert [int(v) for v in sets[4]["nodes"]] == sensor_nodes  # the trace line: sensors only
    k = [int(n) for n in ds15["node_nums"]].index(5)
    assert ds15["x"][k] != 4 / 3 and ds15["x"][k] == pytest.approx(4 / 3, rel=1e-5)  # dataset 15: single precision


def test_candidates_from_a_file_and_fixed_sensors(chain_file, tmp_path, capsys):
    cands = tmp_path / "cands.txt"
    cands.write_text("# where accelerometers fit\n2:x\n3:x  # the tip\n")
    out_json = tmp_path / "p.json"
    code, out, err = run(["plan", str(chain_file), "--modes", "3", "--candidates-file", str(cands), "--fixed", "1:x",
                          "--points", "2", "--json", str(out_json)], capsys)
    assert code == 0, err
    obj = json.loads(out_json.read_text())
    assert obj["fixed"] == [["1:x"]] and ["1:x"] in obj["sensors"]
    assert {d for s in obj["sensors"] for d in s} <= {"1:x", "2:x", "3:x"}
    cands.write_text("2:x\n4:x\n")
    code, _, err = run(["plan", str(chain_file), "--candidates-file", str(cands)], capsys)
    assert code == 2 and "--candidates-file: unknown candidate dof(s) 4:x" in err


def test_plan_command_bad_input(chain_file, capsys):
    code, _, err = run(["plan", str(chain_file), "--sensors", "4"], capsys)
    assert code == 2 and "--sensors: 4 asked, but there are only 3 candidate" in err and "Traceback" not in err
    code, _, err = run(["plan", str(chain_file), "--candidates", "1:x,7:x"], capsys)
    assert code == 2 and "--candidates: unknown candidate dof(s) 7:x" in err
    code, _, err = run(["plan", str(chain_file), "--box", "k1=2000:100"], capsys)
    assert code == 2 and "--box: parameter k1 has lower 2000 >= upper 100" in err
    code, _, err = run(["plan", str(chain_file), "--std-shape", "0"], capsys)
    assert code == 2 and "--std-shape must be > 0" in err
    code, _, err = run(["plan", str(chain_file), "--std-eigenvalue", "5e-324"], capsys)
    assert code == 2 and "--std-eigenvalue must be a finite number >= 1e-100" in err
    code, _, err = run(["plan", str(chain_file), "--modes", "1", "--candidates", "1:x,2:x"], capsys)
    assert code == 2 and "--candidates: 2 candidate dof(s) (1:x, 2:x)" in err and "mn = 2 < 3 parameters" in err
    assert "at least 3 candidate dofs" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_plan_report_draws_the_layout_with_exciters_and_pretest(chain_file, tmp_path, capsys):
    out_json, html1, html2 = tmp_path / "p.json", tmp_path / "p.html", tmp_path / "r.html"
    code, out, err = run(["plan", str(chain_file), "--modes", "2", "--points", "1", "--exciters", "1", "--sensor-mass",
                          "0.01", "--tam", "serep", "--information-gain", "--json", str(out_json), "--report", str(html1)],
                         capsys)
    assert code == 0, err
    assert "exciter(s):" in out and "pretest: serep TAM" in out and "expected information gain" in out
    obj = json.loads(out_json.read_text())
    schema.check(obj, "plan")
    assert obj["segments"] == [["1", "2"], ["2", "3"]]  # the chain's springs join its nodes
    code, _, err = run(["report", str(out_json), "-o", str(html2)], capsys)
    assert code == 0, err
    for page in (html1.read_text(), html2.read_text()):
        assert "The layout on the structure" in page and "<svg" in page
        assert "Pretest correlation" in page and "Exciters (FRF test)" in page and "mass loading" in page
        assert obj["exciters"]["dofs"][0] in page
    code, _, err = run(["plan", str(chain_file), "--exciters", "4", "--points", "1"], capsys)
    assert code == 2 and "--exciters: 4 asked, but there are 3 candidate driving points" in err
