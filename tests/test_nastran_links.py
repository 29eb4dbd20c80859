"""Nastran bar, spring, point-mass and RBE2 cards (femupdate.mesh.nastran_cards): a deck Nastran
itself ran (pyyeti's test model: 117 CBARs and an RBE2) against the eigenvalues Nastran printed;
a hand-written deck against the same model built in Python, in small, large and free field; a
property's modulus as a parameter against the deck with that modulus; bad cards named with their
line, exit 2."""

from __future__ import annotations

import logging
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import femupdate as fu
from femupdate._errors import InputError
from femupdate.modal import model_modes

ENV_PATH = str(Path(__file__).resolve().parents[1] / "src")


def nastran_eigenvalues(out: Path) -> np.ndarray:
    """The first real-eigenvalue table of a Nastran .out file (its EIGENVALUE column)."""
    lines = out.read_text(errors="replace").splitlines()
    start = next(i for i, l in enumerate(lines) if "R E A L   E I G E N V A L U E S" in l)
    vals = []
    for l in lines[start + 4:]:
        parts = l.split()
        if len(parts) != 7 or not parts[0].isdigit():
            break
        vals.append(float(parts[2]))
    return np.array(vals)


def test_a_deck_nastran_ran_gives_nastran_s_eigenvalues(tmp_path):
    """pyyeti's ``full.dat`` (NX Nastran, SOL SEMFREQ, PARAM COUPMASS 1): 49 grids, 117 CBARs with 5
    PBARs, an RBE2 joining grid 33 to the spider grid 330; free-free.  Its frequency-response load
    cards (FREQ, RLOAD2, DAREA, TABLED1) are removed (femupdate refuses cards it does not read).  Nastran
    prints its eigenvalues to 7 digits: the first 23 elastic ones agree to that print (CBAR coupled mass
    without torsional inertia, as Nastran's; with it they differ by 1e-4), the higher ones to 5e-6."""
    pyyeti = pytest.importorskip("pyyeti")
    d = Path(pyyeti.__file__).parent / "tests" / "nas2cam_extseout"
    if not (d / "full.dat").is_file():
        pytest.skip("pyyeti's test files are not installed")
    text = (d / "full.dat").read_text()
    keep = [l for l in text.splitlines() if not re.match(r"^(FREQ|RLOAD2|DAREA|TABLED1|\s+0\.01)", l)]
    (tmp_path / "full.dat").write_text("\n".join(keep) + "\n")
    model = fu.Structure.from_mesh(tmp_path / "full.dat").build()
    assert model.constraints.labels == tuple(f"33:{x}" for x in ("x", "y", "z", "rx", "ry", "rz"))
    ref = nastran_eigenvalues(d / "full.out")
    n = len(ref)
    assert n >= 40
    lam = model_modes(model, n_modes=n).eigenvalues
    assert np.all(np.abs(lam[:6]) < 1e-6 * ref[6])
    rel = np.abs(lam[6:n] - ref[6:]) / ref[6:]
    assert rel[:23].max() < 6e-7, rel[:23]  # modes 7-29: to half a unit in Nastran's seventh digit
    assert rel.max() < 1e-5, rel  # modes 30-50: 1e-6 to 5e-6 (seen), not the print; taken as Nastran's solver
    # without the RBE2 the model is a different structure (the check can fail)
    (tmp_path / "free.dat").write_text("\n".join(l for l in keep if not l.startswith("RBE2")) + "\n")
    lam2 = model_modes(fu.Structure.from_mesh(tmp_path / "free.dat").build(), n_modes=n).eigenvalues
    assert np.max(np.abs(lam2[6:n] - ref[6:]) / ref[6:]) > 1e-3


SMALL = """BEGIN BULK
GRID    1               0.      0.      0.
GRID    2               1.      0.      0.
GRID    3               2.      0.      0.
GRID    4               2.      0.5     0.2
GRID    5               2.      -0.5    0.2
GRID    6               2.      0.      0.4
GRID    7               3.      0.      0.4
CBAR    11      1       1       2       0.      0.      1.
CBAR    12      1       2       3       0.      0.      1.
PBAR    1       7       2.-4    5.-9    3.-9    8.-9
CBEAM   13      2       6       7       4
                        0.      0.02    0.      0.      0.01    0.
PBEAM   2       7       1.-4    2.-9    1.-9    0.      3.-9
MAT1    7       7.+10           0.3     2700.
RBE2    21      6       123456  3       4       5
CONM2   31      6               1.5     0.1     0.      0.
        1.-3    2.-4    2.-3                    3.-3
CELAS2  41      3.+4    4       3       5       3
CELAS1  42      9       7       2
PELAS   9       5.+3
SPC1    1       123456  1
ENDDATA
"""


def twin():
    """The deck's model built by hand: G = E / (2 (1 + nu)); I1 is frame3d's Iz, I2 its Iy; the CBEAM's
    orientation from its grid G0 = 4, x_4 - x_6; CONM2's I21 enters the tensor as -I21."""
    E, nu, rho = 7e10, 0.3, 2700.0
    G = E / (2 * (1 + nu))
    s = fu.Structure("deck")
    for i, x in {1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0), 4: (2, 0.5, 0.2), 5: (2, -0.5, 0.2), 6: (2, 0, 0.4),
                 7: (3, 0, 0.4)}.items():
        s.node(i, x)
    s.frame3d([[1, 2], [2, 3]], E=E, G=G, A=2e-4, Iy=3e-9, Iz=5e-9, J=8e-9, rho=rho, orientation=(0, 0, 1),
              torsion_mass=False)
    s.frame3d([6, 7], E=E, G=G, A=1e-4, Iy=1e-9, Iz=2e-9, J=3e-9, rho=rho, orientation=(0, 0.5, -0.2),
              offsets=[[0, 0.02, 0], [0, 0.01, 0]])
    s.rigid_link(6, [3, 4, 5])
    s.point_mass(6, 1.5, offset=[0.1, 0, 0], inertia=[[1e-3, -2e-4, 0], [-2e-4, 2e-3, 0], [0, 0, 3e-3]])
    s.spring(["4:z", "5:z"], k=3e4)
    s.spring(["7:y"], k=5e3)
    s.support_node([1])
    return s.build()


def free_field(deck: str) -> str:
    """The same cards in free field (commas), continuations as a comma-led line."""
    out = []
    for line in deck.splitlines():
        if line.startswith(("BEGIN", "ENDDATA")):
            out.append(line)
            continue
        head = line[:8].strip()
        fields = [line[8 + 8 * k:16 + 8 * k].strip() for k in range(8)]
        while fields and fields[-1] == "":
            fields.pop()
        out.append(",".join([head] + fields))
    return "\n".join(out) + "\n"


def large_field(deck: str) -> str:
    """The same cards in large field: each 8-field line as two 4-field lines of 16 characters."""
    out = []
    for line in deck.splitlines():
        if line.startswith(("BEGIN", "ENDDATA")):
            out.append(line)
            continue
        head = line[:8].strip()
        fields = [line[8 + 8 * k:16 + 8 * k].strip() for k in range(8)]
        first = (head + "*") if head else "*"
        out.append(f"{first:<8}" + "".join(f"{f:<16}" for f in fields[:4]))
        out.append(f"{'*':<8}" + "".join(f"{f:<16}" for f in fields[4:]))
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("form", ["small", "free", "large"])
def test_rbe2_conm2_celas_cbar_cbeam_deck_equals_the_python_model(tmp_path, form):
    deck = {"small": SMALL, "free": free_field(SMALL), "large": large_field(SMALL)}[form]
    (tmp_path / "deck.bdf").write_text(deck)
    a = fu.Structure.from_mesh(tmp_path / "deck.bdf").build()
    b = twin()
    assert a.dofs == b.dofs and a.constraints.labels == b.constraints.labels
    for A, B in ((a.K0, b.K0), (a.M0, b.M0)):
        assert abs(A - B).max() <= 1e-12 * abs(B).max()


def test_a_property_modulus_as_a_parameter_is_exact(tmp_path):
    """[mesh.sets."1"] E = "E_bar": G J enters as E · J / (2 (1 + nu)); the model at E_bar = 2 E equals the
    deck whose MAT1 says 2 E (both bars and their torsion)."""
    (tmp_path / "deck.bdf").write_text(SMALL)
    (tmp_path / "m.toml").write_text('[parameters.E_bar]\nvalue = 7e10\n[mesh]\nfile = "deck.bdf"\n'
                                     '[mesh.sets."1"]\nE = "E_bar"\nnu = 0.3\n')
    from femupdate.io.model_file import load_model

    m = load_model(tmp_path / "m.toml")
    stiff = SMALL.replace("PBAR    1       7", "PBAR    1       8").replace(
        "ENDDATA", "MAT1    8       1.4+11          0.3     2700.\nENDDATA")
    (tmp_path / "stiff.bdf").write_text(stiff)
    ref = fu.Structure.from_mesh(tmp_path / "stiff.bdf").build()
    K = m.K({"E_bar": 1.4e11})
    assert m.dofs == ref.dofs and abs(K - ref.K()).max() <= 1e-12 * abs(ref.K()).max()


@pytest.mark.parametrize("card, message", [
    ("CBAR    11      1       1       2       0.      0.      1.\n        1", "pin flags PA = 1"),
    ("PBAR    1       7       2.-4    5.-9    3.-9    8.-9    1.", "non-structural mass NSM = 1."),
    ("CONM2   31      6       5       1.5", "CONM2 in coordinate system CID = 5"),
    ("CELAS1  42      99      7       2", "property PELAS 99 is not defined"),
    ("RBE2    22      2       123     4", "dof 4:z is dependent twice"),
    ("RBE3    23              6       123456  1.      123     4       5", "RBE3 (deck.bdf:"),
    ("CELAS2  43      1.      70      3", "node 70 is not defined"),
    ("RBE2    24      6       127     4", "component CM '127'"),
])
def test_bad_cards_are_named_with_their_line(tmp_path, card, message):
    deck = SMALL.replace("ENDDATA", card + "\nENDDATA")
    if card.startswith(("CBAR", "PBAR", "CONM2", "CELAS1")):  # replace the deck's own card
        name = card.split()[0]
        deck = "\n".join(l for l in SMALL.splitlines() if not (l.startswith(name) and l.split()[1] == card.split()[1])
                         and not (name == "CONM2" and l.startswith("        1.-3")))
        deck = deck.replace("ENDDATA", card + "\nENDDATA")
    (tmp_path / "deck.bdf").write_text(deck)
    with pytest.raises(InputError) as exc:
        fu.Structure.from_mesh(tmp_path / "deck.bdf").build()
    assert message in str(exc.value), str(exc.value)
    assert "deck.bdf" in str(exc.value)


def test_bad_card_from_the_command_line_exits_2(tmp_path):
    (tmp_path / "deck.bdf").write_text(SMALL.replace("ENDDATA", "RBE2    22      2       123     4\nENDDATA"))
    (tmp_path / "m.toml").write_text('[mesh]\nfile = "deck.bdf"\n')
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "m.toml"], cwd=tmp_path, capture_output=True,
                       text=True, env={"PYTHONPATH": ENV_PATH, "PATH": "/usr/bin:/bin"})
    assert r.returncode == 2 and "dof 4:z is dependent twice" in r.stderr and "RBE2 22" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


def test_what_is_not_modelled_is_listed(tmp_path, caplog):
    (tmp_path / "deck.bdf").write_text(SMALL)
    with caplog.at_level(logging.WARNING):
        fu.Structure.from_mesh(tmp_path / "deck.bdf")
    text = caplog.text
    assert "shear flexibility of PBEAM 2" in text and "default lumped mass of CBAR/CBEAM" in text


def test_deck_with_rbe2_through_modes_and_update(tmp_path):
    """The deck's bar modulus as a parameter: ``modes --set E_bar=8.4e10 --uff`` writes the shapes on every
    dof, the RBE2's dependent ones recovered; ``update`` refuses those by name (they are not model dofs)
    and, measured at independent nodes only, recovers E_bar."""
    import json

    (tmp_path / "deck.bdf").write_text(SMALL)
    (tmp_path / "m.toml").write_text('[parameters.E_bar]\nvalue = 7e10\nbounds = [1e10, 2e11]\n[mesh]\nfile = "deck.bdf"\n'
                                     '[mesh.sets."1"]\nE = "E_bar"\nnu = 0.3\n')
    env = {"PYTHONPATH": ENV_PATH, "PATH": "/usr/bin:/bin"}
    run = [sys.executable, "-m", "femupdate"]
    r = subprocess.run(run + ["modes", "m.toml", "--n-modes", "6", "--set", "E_bar=8.4e10", "--uff", "t.uff"],
                       cwd=tmp_path, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(run + ["update", "m.toml", "t.uff"], cwd=tmp_path, capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "3:x, 3:y, 3:z, 3:rx, 3:ry, 3:rz, 4:z, 5:z: dependent dofs of rigid links" in r.stderr
    sensors = "2:x,2:y,2:z,6:x,6:y,6:z,7:x,7:y,7:z"
    r = subprocess.run(run + ["update", "m.toml", "t.uff", "--measured-dofs", sensors, "--json", "u.json"],
                       cwd=tmp_path, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert abs(json.loads((tmp_path / "u.json").read_text())["parameters"]["E_bar"] / 8.4e10 - 1) < 1e-6


def test_spc1_on_a_node_that_only_a_conm2_and_a_celas_use(tmp_path):
    """A grid with a CONM2 (translations only) and a CELAS2 on x, held in y and z by SPC1: x stays free."""
    deck = SMALL.replace("ENDDATA", "GRID    50              5.      0.      0.\nCONM2   51      50              2.0\n"
                                    "CELAS2  52      1.+3    50      1       7       1\nSPC1    1       23      50\nENDDATA")
    (tmp_path / "deck.bdf").write_text(deck)
    m = fu.Structure.from_mesh(tmp_path / "deck.bdf").build()
    assert [d for d in m.dofs if d.startswith("50:")] == ["50:x"]
