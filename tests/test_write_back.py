"""Updated values written back into the FE code's language (femupdate.io.write_back): a Nastran
deck and an Abaqus deck updated, written back, and read again by femupdate's own deck readers:
the model of the written deck has the frequencies the update found; ANSYS commands; bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import femupdate
from femupdate import InputError, MeasuredMode, TestData, load_model, model_modes, update
from femupdate.io.write_back import plan, write_back
from femupdate.mesh.nastran import cards


def _plate_grid(n=3, a=0.3):
    ids, xyz = [], []
    for j in range(n + 1):
        for i in range(n + 1):
            ids.append(1 + i + (n + 1) * j)
            xyz.append((a * i / n, a * j / n))
    corner = [1 + i + (n + 1) * j for j in range(n) for i in range(n)]  # each quad's first node
    quads = [[c, c + 1, c + n + 2, c + n + 1] for c in corner]
    clamped = [1 + i for i in range(n + 1)]  # the edge y = 0
    return ids, xyz, quads, clamped


def nastran_deck(E="7.0+10", t="0.002", rho="2700."):
    ids, xyz, quads, clamped = _plate_grid()
    out = ["SOL 103", "CEND", "BEGIN BULK"]
    out += [f"GRID    {i:<8d}        {x:<8.4f}{y:<8.4f}0.0" for i, (x, y) in zip(ids, xyz)]
    out += [f"CQUAD4  {k + 1:<8d}1       " + "".join(f"{v:<8d}" for v in q) for k, q in enumerate(quads)]
    out += [f"PSHELL  1       3       {t:<8s}3               3", f"MAT1    3       {E:<8s}        0.33    {rho:<8s}",
            "SPC1    1       123456  " + "".join(f"{c:<8d}" for c in clamped), "ENDDATA"]
    return "\n".join(out) + "\n"


def abaqus_deck(E="7.0e10", t="0.002", rho="2700."):
    ids, xyz, quads, clamped = _plate_grid()
    out = ["*HEADING", "plate", "*NODE"] + [f"{i}, {x}, {y}, 0.0" for i, (x, y) in zip(ids, xyz)]
    out += ["*ELEMENT, TYPE=S4, ELSET=PLATE"] + [f"{k + 1}, " + ", ".join(map(str, q)) for k, q in enumerate(quads)]
    out += ["*MATERIAL, NAME=ALU", "*ELASTIC", f"{E}, 0.33", "*DENSITY", f"{rho},",
            "*SHELL SECTION, ELSET=PLATE, MATERIAL=ALU", f"{t}, 5", "*BOUNDARY"] + [f"{c}, ENCASTRE" for c in clamped]
    return "\n".join(out) + "\n"


def _model_file(d: Path, deck: str, sets: str, params: str) -> Path:
    p = d / "plate.toml"
    p.write_text(f"{params}\n[mesh]\nfile = \"{deck}\"\n\n{sets}", encoding="utf-8")
    return p


def _updated(model, truth: dict):
    tm = model_modes(model, truth)
    data = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[j], model.dofs, tm.shapes[:, j]) for j in range(4)))
    return update(model, data)


@pytest.mark.parametrize("code", ["nastran", "abaqus"])
def test_round_trip_through_the_deck(tmp_path, code):
    """Update E (through a [mesh.sets] set), write it back, read the written deck with femupdate's
    own reader (no parameter: the deck's values): its K and M are the updated model's, its
    frequencies the update's."""
    deck = "plate.bdf" if code == "nastran" else "plate.inp"
    (tmp_path / deck).write_text(nastran_deck() if code == "nastran" else abaqus_deck(), encoding="utf-8")
    sets = "[mesh.sets.1]\nE = \"E_plate\"\n" if code == "nastran" else "[mesh.sets.PLATE]\nE = \"E_plate\"\n"
    p = _model_file(tmp_path, deck, sets, "[parameters.E_plate]\nvalue = 7.0e10\nbounds = [1e10, 2e11]\n")
    model = load_model(p)
    res = _updated(model, {"E_plate": 6.6123456789e10})
    assert res.success and res.parameters["E_plate"] == pytest.approx(6.6123456789e10, rel=1e-7)
    (written,) = write_back(p, {"E_plate": res.parameters["E_plate"]}, tmp_path / "out")
    assert written.name == deck.replace(".", "_updated.")
    text = written.read_text()
    if code == "abaqus":  # the *ELASTIC line: E in full (repr), ν kept
        lines = text.splitlines()
        e, nu = lines[lines.index("*ELASTIC") + 1].split(",")
        assert float(e) == res.parameters["E_plate"] and nu.strip() == "0.33"
    if code == "nastran":
        mat = [c for c in cards(written) if c[0] == "MAT1"]
        assert mat == [("MAT1", ["3", f"{res.parameters['E_plate']:.10E}", "", "0.33", "2700."], mat[0][2])]
    reread = load_model(_model_file(tmp_path / "out", written.name, sets.replace('E = "E_plate"', ""), ""))
    at = model.with_values(res.parameters)
    assert reread.dofs == model.dofs
    assert abs(reread.K() - at.K()).max() <= 1e-10 * abs(at.K()).max()  # eleven digits in the deck
    assert abs(reread.M() - at.M()).max() <= 1e-12 * abs(at.M()).max()
    # the eigenvalues to what the eigen-solution resolves (eps · λmax / λ1 is about 1e-7 for the first)
    f_update = model_modes(model, res.parameters).eigenvalues[:6]
    f_deck = model_modes(reread).eigenvalues[:6]
    np.testing.assert_allclose(f_deck, f_update, rtol=1e-6)
    # the deck as it was reads as the start: the written deck, not the table, carries the value
    start = load_model(_model_file(tmp_path, deck, sets.replace('E = "E_plate"', ""), ""))
    assert abs(start.K() - model.K()).max() <= 1e-12 * abs(model.K()).max()


def test_explicit_cards_each_code(tmp_path):
    """card = ... on each code's table: the Nastran PSHELL thickness (the card re-read: fields and
    thickness), Abaqus *SHELL SECTION, *DENSITY and *PARAMETER lines, ANSYS MP and RMODIF commands."""
    (tmp_path / "plate.bdf").write_text(nastran_deck(), encoding="utf-8")
    p = _model_file(tmp_path, "plate.bdf", "", "[parameters.t]\nvalue = 0.002\ncard = \"PSHELL 1 T\"\n"
                    "[parameters.E]\nvalue = 7e10\ncard = \"MAT1 3 E\"\n")
    (out,) = write_back(p, {"t": 0.0021234567891, "E": 7.1e10}, tmp_path / "nas")
    ps = [c for c in cards(out) if c[0] == "PSHELL"][0][1]
    assert ps[:4] == ["1", "3", "2.1234567891E-03", "3"] and float(ps[2]) == pytest.approx(0.0021234567891, rel=1e-10)
    s = femupdate.Structure.from_mesh(out).build()
    assert s.n_dofs > 0
    deck = tmp_path / "plate.inp"
    deck.write_text(abaqus_deck().replace("*HEADING", "*HEADING\n*PARAMETER\nE_alu = 7.0e10\nrho = 2700."), encoding="utf-8")
    q = tmp_path / "m.toml"
    q.write_text('[abaqus]\nstiffness = "s.mtx"\nmass = "m.mtx"\ndeck = "plate.inp"\n'
                 '[parameters.t]\nvalue = 0.002\ncard = "SHELL SECTION plate"\n'
                 '[parameters.r]\nvalue = 2700.0\ncard = "DENSITY alu"\n'
                 '[parameters.e]\nvalue = 7e10\ncard = "PARAMETER E_alu"\n', encoding="utf-8")
    (out,) = write_back(q, {"t": 0.0025, "r": 2650.5, "e": 7.25e10}, tmp_path / "abq")
    lines = out.read_text().splitlines()
    assert "E_alu = 72500000000.0" in lines and "rho = 2700." in lines
    assert lines[lines.index("*DENSITY") + 1] == "2650.5," and "0.0025, 5" in lines
    a = tmp_path / "a.toml"
    a.write_text('[ansys]\nfull = "file.full"\n[parameters.E]\nvalue = 2e11\nscales = "K"\ncard = "MP,EX,1"\n'
                 '[parameters.A]\nvalue = 0.01\nscales = "M"\ncard = "R,2,1"\n', encoding="utf-8")
    (mac,) = write_back(a, {"E": 2.123e11, "A": 0.0125}, tmp_path / "ans")
    assert mac.name == "a_updated.mac"
    cmds = [ln.split("!")[0].strip() for ln in mac.read_text().splitlines() if ln and not ln.startswith("!")]
    assert cmds == ["/PREP7", "MP,EX,1,212300000000.0", "RMODIF,2,1,0.0125"]


def test_bad_write_backs_named(tmp_path):
    (tmp_path / "plate.bdf").write_text(nastran_deck(), encoding="utf-8")
    p = _model_file(tmp_path, "plate.bdf", "[mesh.sets.1]\nE = \"E\"\n", "[parameters.E]\nvalue = 7e10\n"
                    "[parameters.k]\nvalue = 1.0\n")
    with pytest.raises(InputError, match=r"parameter\(s\) k of .*plate\.toml map to no card"):
        plan(p, {"E": 7.1e10, "k": 2.0})
    p.write_text(p.read_text().replace("[parameters.k]\nvalue = 1.0\n", "[parameters.k]\nvalue = 1.0\ncard = \"MAT1 9 E\"\n"))
    with pytest.raises(InputError, match=r"plate\.bdf has no card MAT1 9"):
        write_back(p, {"k": 2.0}, tmp_path / "o")
    p.write_text(p.read_text().replace('card = "MAT1 9 E"', 'card = "MAT1 3 YIELD"'))
    with pytest.raises(InputError, match=r"\[parameters\.k\]: card 'MAT1 3 YIELD': MAT1 takes an id and one of E, G"):
        plan(p, {"k": 2.0})
    p.write_text(p.read_text().replace('card = "MAT1 3 YIELD"', 'card = "ELASTIC ALU"'))
    with pytest.raises(InputError, match=r"card 'ELASTIC ALU' is a Abaqus card, but the deck plate\.bdf is nastran"):
        plan(p, {"k": 2.0})
    p.write_text(p.read_text().replace('card = "ELASTIC ALU"', 'card = "MAT1 3 E"'))
    with pytest.raises(InputError, match=r"parameters E and k both write MAT1 3 E"):
        plan(p, {"E": 7.1e10, "k": 2.0})


def test_cli_write_back(tmp_path, capsys, monkeypatch):
    """``femupdate write-back MODEL RESULT --out DIR``: the result's updated parameters into the deck;
    bad input exits 2 naming the parameter, without a traceback."""
    from femupdate.cli import main

    (tmp_path / "plate.bdf").write_text(nastran_deck(), encoding="utf-8")
    p = _model_file(tmp_path, "plate.bdf", "[mesh.sets.1]\nE = \"E\"\n", "[parameters.E]\nvalue = 7e10\n")
    (tmp_path / "u.json").write_text(json.dumps({"kind": "update", "schema_version": 1, "parameters": {"E": 6.9e10},
                                                 "updated": ["E"], "success": True}))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["write-back", str(p), "u.json", "--out", "deck"])
    assert info.value.code == 0 and "deck/plate_updated.bdf" in capsys.readouterr().out.replace("\\", "/")
    assert [c for c in cards(tmp_path / "deck" / "plate_updated.bdf") if c[0] == "MAT1"][0][1][1] == "6.9000000000E+10"
    for result, needle in (({"parameters": {"E": 6.9e10, "k": 1.0}, "updated": ["E", "k"], "success": True},
                            "parameter(s) k of"),
                           ({"parameters": {"E": 6.9e10}, "updated": ["E"], "success": False},
                            "the run did not succeed: nothing to write back")):
        (tmp_path / "v.json").write_text(json.dumps(dict(result, kind="update", schema_version=1)))
        with pytest.raises(SystemExit) as info:
            main(["write-back", str(p), "v.json", "--out", "deck"])
        err = capsys.readouterr().err
        assert info.value.code == 2 and needle in err and "Traceback" not in err, err


def test_a_written_deck_never_replaces_the_deck_it_edits(tmp_path, capsys, monkeypatch):
    """``--out`` holding a link named like the output that leads back to the input deck: refused
    (exit 2, the deck named), and the deck is left as it was."""
    import os

    from femupdate.cli import main

    deck = tmp_path / "plate.bdf"
    deck.write_text(nastran_deck(), encoding="utf-8")
    before = deck.read_bytes()
    p = _model_file(tmp_path, "plate.bdf", "[mesh.sets.1]\nE = \"E\"\n", "[parameters.E]\nvalue = 7e10\n")
    (tmp_path / "u.json").write_text(json.dumps({"kind": "update", "schema_version": 1, "parameters": {"E": 6.9e10},
                                                 "updated": ["E"], "success": True}))
    (tmp_path / "out").mkdir()
    os.symlink(deck, tmp_path / "out" / "plate_updated.bdf")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["write-back", str(p), "u.json", "--out", "out"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and "plate.bdf" in err and "Traceback" not in err, err
    assert deck.read_bytes() == before


def test_pbar_fields_and_a_mat1_with_g_and_nu(tmp_path):
    """PBAR A and I1 land in their fields (re-read by femupdate's card reader), the card's other
    fields kept; a MAT1 that gives E, G and NU gets G = E / 2(1 + NU), so the deck stays
    consistent (femupdate's reader refuses a G that disagrees)."""
    deck = tmp_path / "bar.bdf"
    deck.write_text("BEGIN BULK\nPBAR    7       3       0.01    2.0-6   3.0-6   4.0-6   0.5\n"
                    "MAT1    3       7.0+10  2.6+10  0.33    2700.\nENDDATA\n", encoding="utf-8")
    p = tmp_path / "m.toml"
    p.write_text('[nastran]\ndmig = "x.pch"\nK = "KAAX"\nM = "MAAX"\ndeck = "bar.bdf"\n'
                 '[parameters.A]\nvalue = 0.01\ncard = "PBAR 7 A"\n[parameters.I]\nvalue = 2e-6\ncard = "pbar 7 i1"\n'
                 '[parameters.E]\nvalue = 7e10\ncard = "MAT1 3 E"\n', encoding="utf-8")
    (out,) = write_back(p, {"A": 0.0123, "I": 2.5e-6, "E": 7.3e10}, tmp_path / "o")
    got = {c[0]: c[1] for c in cards(out)}
    assert got["PBAR"] == ["7", "3", "1.2300000000E-02", "2.5000000000E-06", "3.0-6", "4.0-6", "0.5"]
    assert got["MAT1"][:2] == ["3", "7.3000000000E+10"] and got["MAT1"][3:] == ["0.33", "2700."]
    assert float(got["MAT1"][2]) == pytest.approx(7.3e10 / 2.66, rel=1e-10)


def test_update_write_back_option(tmp_path, capsys, monkeypatch):
    """``update --write-back DIR`` writes the deck after a converged update (the value the update
    found); a parameter without a card stops with exit 2 before any file is written."""
    from femupdate.cli import main

    (tmp_path / "plate.bdf").write_text(nastran_deck(), encoding="utf-8")
    p = _model_file(tmp_path, "plate.bdf", "[mesh.sets.1]\nE = \"E\"\n", "[parameters.E]\nvalue = 7e10\n"
                    "bounds = [1e10, 2e11]\n")
    lam = model_modes(load_model(p), {"E": 7.35e10}).eigenvalues[:3]
    (tmp_path / "f.json").write_text(json.dumps({"modes": [{"eigenvalue": float(v)} for v in lam]}))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["update", str(p), "f.json", "--write-back", "out", "--json", "u.json"])
    assert info.value.code == 0, capsys.readouterr().err
    assert "wrote out/plate_updated.bdf" in capsys.readouterr().out.replace("\\", "/")
    e = float([c for c in cards(tmp_path / "out" / "plate_updated.bdf") if c[0] == "MAT1"][0][1][1])
    assert e == pytest.approx(json.loads((tmp_path / "u.json").read_text())["parameters"]["E"], rel=1e-10)
    assert e == pytest.approx(7.35e10, rel=1e-7)
    # a spring beside the mesh: its parameter k has no card
    p.write_text(p.read_text().replace("[mesh]", "[parameters.k]\nvalue = 1000.0\nbounds = [1.0, 1e6]\n\n[mesh]")
                 + '\n[[element]]\ntype = "spring"\ndofs = ["16:z"]\nk = "k"\n')
    lam = model_modes(load_model(p), {"E": 7.35e10, "k": 1000.0}).eigenvalues[:3]
    (tmp_path / "f.json").write_text(json.dumps({"modes": [{"eigenvalue": float(v)} for v in lam]}))
    with pytest.raises(SystemExit) as info:
        main(["update", str(p), "f.json", "--write-back", "out2"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and "parameter(s) k of" in err and "map to no card" in err, err
    assert not (tmp_path / "out2").exists() and "Traceback" not in err
