"""Nastran matrices read through pyyeti (skipped without it), on files Nastran itself wrote and
that pyyeti ships for its own tests: an OP4 of KAA and MAA with the a-set's USET from the OP2 of
the same run, checked against the eigenvalues Nastran computed in that run (LAMA, in the same
OP4); DMIG matrices of a punch file, checked against the same matrices in an OP2."""

from pathlib import Path

import numpy as np
import pytest

from femupdate import InputError, model_modes
from femupdate.io.model_file import load_model

pyyeti = pytest.importorskip("pyyeti")
DATA = Path(pyyeti.__file__).parent / "tests"
if not (DATA / "nas2cam_extseout" / "nas2cam.op4").is_file():  # a pyyeti install without its test data
    pytest.skip("pyyeti's test files are not installed", allow_module_level=True)


def toml(tmp_path, text):
    (tmp_path / "m.toml").write_text(text)
    return tmp_path / "m.toml"


def test_kaa_and_maa_of_an_op4_with_the_a_set_of_the_op2_give_nastran_s_eigenvalues(tmp_path):
    d = DATA / "nas2cam_extseout"
    path = toml(tmp_path, f'[model]\nname = "nas2cam residual"\n[nastran]\nop4 = "{d / "nas2cam.op4"}"\n'
                          f'op2 = "{d / "nas2cam.op2"}"\nset = "a"\nK = "KAA"\nM = "MAA"\n')
    model = load_model(path)
    assert model.n_dofs == 54
    assert model.dofs[:2] == ("1995001:s", "1995002:s") and model.dofs[22:28] == ("3:x", "3:y", "3:z", "3:rx", "3:ry", "3:rz")
    from pyyeti.nastran import op4

    lam = op4.read(str(d / "nas2cam.op4"), ["lambda"])["lambda"].ravel()  # Nastran's eigenvalues (rad²/s²)
    modes = model_modes(model)
    assert modes.n_rigid == 6 and np.all(np.abs(lam[:6]) < 1e-6)
    np.testing.assert_allclose(modes.eigenvalues[6:30], lam[6:30], rtol=1e-7)


def test_dmig_matrices_are_labelled_by_their_own_grids(tmp_path):
    """The punch and the OP2 of the same matrices agree; IDENT (symmetric form) as K and M gives
    21 modes at 1 rad²/s², PATRN (a_ij = j, square form) is refused as not symmetric."""
    from femupdate.io.nastran import read_dmig

    f = DATA / "nastran_dmig_data"
    labels, ident = read_dmig(f / "matrix_factory.pch", "ident")
    labels2, ident2 = read_dmig(f / "matrix.op2", "mident")
    assert labels == labels2 and labels[:7] == ["1:x", "1:y", "1:z", "1:rx", "1:ry", "1:rz", "2:x"]
    np.testing.assert_array_equal(ident, np.eye(21))
    np.testing.assert_allclose(read_dmig(f / "matrix_factory.pch", "randm")[1], read_dmig(f / "matrix.op2", "mrandm")[1],
                               rtol=1e-9)
    model = load_model(toml(tmp_path, f'[nastran]\ndmig = "{f / "matrix_factory.pch"}"\nK = "IDENT"\nM = "IDENT"\n'))
    assert model.dofs == tuple(labels)
    np.testing.assert_allclose(model_modes(model).eigenvalues, np.ones(21), rtol=1e-12)
    with pytest.raises(InputError, match=r"K0 is not symmetric"):
        load_model(toml(tmp_path, f'[nastran]\ndmig = "{f / "matrix_factory.pch"}"\nK = "PATRN"\nM = "IDENT"\n'))


def test_nastran_hazards_are_refused_by_name(tmp_path):
    f = DATA / "nastran_dmig_data"
    d = DATA / "nas2cam_extseout"
    cases = [
        (f'[nastran]\ndmig = "{f / "matrix_factory.pch"}"\nK = "RANDM"\nM = "IDENT"\n', r"K0 is not symmetric"),
        (f'[nastran]\ndmig = "{f / "matrix_factory.pch"}"\nK = "CMPLX"\nM = "IDENT"\n',
         r"DMIG CMPLX of .*matrix_factory\.pch has 21 rows and 50 columns on different dofs"),
        (f'[nastran]\ndmig = "{f / "matrix_factory.pch"}"\nK = "KAAX"\nM = "IDENT"\n',
         r"holds no DMIG matrix 'KAAX' \(it holds patrn, ident, randm, cmplx\)"),
        (f'[nastran]\nop4 = "{d / "nas2cam.op4"}"\nop2 = "{d / "nas2cam.op2"}"\nset = "g"\nK = "KAA"\nM = "MAA"\n',
         r"KAA is 54 × 54, but set 'g' of .*nas2cam\.op2 has 60 dofs"),
        (f'[nastran]\nop4 = "{d / "nas2cam.op4"}"\nop2 = "{d / "nas2cam.op2"}"\nK = "KGG"\nM = "MAA"\n',
         r"nas2cam\.op4 holds no matrix 'KGG' \(it holds se_start, ulvs, maa, kaa"),
    ]
    for text, message in cases:
        with pytest.raises(InputError, match=message):
            load_model(toml(tmp_path, text))


def test_without_pyyeti_the_reader_says_what_to_install(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pyyeti.nastran", None)  # import fails as if pyyeti were absent
    path = toml(tmp_path, '[nastran]\ndmig = "k.pch"\nK = "KAAX"\nM = "MAAX"\n')
    (tmp_path / "k.pch").write_text("DMIG    KAAX           0       6       2       0\n")
    with pytest.raises(InputError, match=r"needs pyyeti: pip install pyyeti \(or femupdate\[nastran\]\)"):
        load_model(path)


def test_the_uset_of_a_param_post_op2_labels_grids_and_scalar_points():
    """inboard.op2 (PARAM,POST,-1) read through rdparampost: its grids' six components in USET order
    and the eight SPOINTs the deck declares (SPOINT 2995001 THRU 2995008) as scalar points."""
    from femupdate.io.nastran import set_labels

    labels = set_labels(DATA / "nas2cam_extseout" / "inboard.op2", "a")
    assert labels[:6] == ["3:x", "3:y", "3:z", "3:rx", "3:ry", "3:rz"]
    assert labels[-8:] == [f"{2995001 + k}:s" for k in range(8)]
    assert len(set(labels)) == len(labels)


CHAIN_PCH = """DMIG    KAAX           0       6       2       0       0               2
DMIG*   KAAX                           1               1
*                      1               1 6.000000000D+00
*                      2               1-6.000000000D+00
DMIG*   KAAX                           2               1
*                      2               1 6.000000000D+00
DMIG    MAAX           0       6       2       0       0               2
DMIG*   MAAX                           1               1
*                      1               1 2.000000000D+00
DMIG*   MAAX                           2               1
*                      2               1 4.000000000D+00
DMIG    KK1            0       6       2       0       0               1
DMIG*   KK1                            1               1
*                      1               1 1.000000000D+00
DMIG    KK7            0       6       2       0       0               1
DMIG*   KK7                            7               1
*                      7               1 1.000000000D+00
"""


def test_a_dmig_on_some_of_the_dofs_is_placed_on_them(tmp_path):
    """KK1 (grid 1 only) beside KAAX (grids 1, 2): the chain k1 + k2, masses 2 and 4; its
    eigenvalues at k1 = 8, k2 = 6 in closed form: the roots of 8 λ² − (4·14 + 2·6) λ + (14·6 − 36) = 0."""
    (tmp_path / "chain.pch").write_text(CHAIN_PCH)
    model = load_model(toml(tmp_path, '[nastran]\ndmig = "chain.pch"\nK = "KAAX"\nM = "MAAX"\n'
                                      '[parameters.k1]\nvalue = 7.0\nK = "KK1"\n'))
    assert model.dofs == ("1:x", "2:x")
    a, b, c = 8.0, -(4 * 14 + 2 * 6), 14 * 6 - 36
    exact = sorted([(-b - np.sqrt(b * b - 4 * a * c)) / (2 * a), (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)])
    np.testing.assert_allclose(model_modes(model, {"k1": 8.0}).eigenvalues, exact, rtol=1e-12)
    bad = toml(tmp_path, '[nastran]\ndmig = "chain.pch"\nK = "KAAX"\nM = "MAAX"\n[parameters.k7]\nvalue = 1.0\nK = "KK7"\n')
    with pytest.raises(InputError, match=r"DMIG KK7 has dof\(s\) 7:x that KAAX does not have"):
        load_model(bad)
