"""Parameter units: inferred from the element properties a parameter stands for, carried by the
model, shown in the terminal tables and written to the JSON results (issue 18)."""

from __future__ import annotations

import json

import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.structure.units import parameter_units, property_unit


def _structure():
    s = fu.Structure("units")
    for name in ("k", "kr", "m", "E", "A", "I", "rho", "EA", "k12", "k6", "k2", "mixed"):
        s.parameter(name, 1.0)
    for i in range(1, 7):
        s.node(i, (float(i), 0.0, 0.0))
    s.beam2d([1, 2], E="E", A=1e-3, I=1e-6, rho=7800.0)  # one parameter per term: the model stays affine
    s.beam2d([2, 3], E=2e11, A="A", I=1e-6, rho=7800.0)
    s.beam2d([3, 4], E=2e11, A=1e-3, I="I", rho=7800.0)
    s.beam2d([4, 5], E=2e11, A=1e-3, I=1e-6, rho="rho")
    s.beam2d_terms([5, 6], EA_l="EA", k12="k12", k6="k6", k2="k2", rho=7800.0, A=1e-3)
    s.spring(["3:x"], k="k")
    s.spring(["3:rz"], k="kr")
    s.mass(["3:y"], m="m")
    s.spring(["2:y"], k="mixed")
    s.spring(["2:rz"], k="mixed")  # the same parameter on a translation and on a rotation: no single unit
    return s


def test_units_follow_the_properties():
    model = _structure().build()
    got = {p.name: p.unit for p in model.parameters}
    assert got == {"k": "N/m", "kr": "N·m/rad", "m": "kg", "E": "Pa", "A": "m²", "I": "m⁴", "rho": "kg/m³",
                   "EA": "N/m", "k12": "N/m", "k6": "N/rad", "k2": "N·m/rad", "mixed": ""}
    # a copy keeps them
    assert model.with_values({"k": 2.0}).parameters[0].unit == "N/m"


def test_property_unit_of_lumped_elements_depends_on_the_dofs():
    assert property_unit("mass", "m", ["1:rx"]) == "kg·m²"
    assert property_unit("spring", "k", ["1:x", "2:x"]) == "N/m"
    assert property_unit("spring", "k", ["1:x", "2:rz"]) == ""
    assert parameter_units([], ["p"]) == {"p": ""}


def test_a_unit_given_in_python_is_kept_and_checked():
    s = fu.Structure("given")
    s.parameters["k"] = fu.Parameter("k", 1.0, unit="kN/mm")
    s.spring(["1:x"], k="k")
    s.mass(["1:x"], m=1.0)
    assert s.build().parameters[0].unit == "kN/mm"
    with pytest.raises(fu.InputError, match="unit must be a string"):
        fu.Parameter("k", 1.0, unit=3)


def test_results_and_tables_carry_units(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(tmp_path)])
    capsys.readouterr()
    out = tmp_path / "r.json"
    with pytest.raises(SystemExit) as e:
        main(["update", str(tmp_path / "two_dof.toml"), str(tmp_path / "two_dof_frequencies.json"), "--json", str(out)])
    assert e.value.code == 0
    text = capsys.readouterr().out
    assert "unit" in text and "N/m" in text
    r = json.loads(out.read_text())
    assert r["parameter_units"] == {"k1": "N/m", "k2": "N/m"}
    assert r["bounds"] == {"k1": [3.0, 13.0], "k2": [1.0, 11.0]}
