"""Model reduction and expansion: Guyan, IRS, Kammer modal/hybrid, SEREP, metrics, criteria,
selection, super-elements, ``femupdate reduce``, the paper sections and the benchmark."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from femupdate import InputError, Structure, model_modes
from femupdate.cli import main
from femupdate.examples import chain
from femupdate.generators import frame_lattice
from femupdate.reduction import (
    ExpandedShapes, ExpansionBiasWarning, Reducer, assemble, effective_independence, expand, guyan, irs,
    kammer_hybrid, kammer_modal, mass_fraction, reduce, reduced_eigenvalues, reduced_matrices, reduction_criteria,
    serep, superelement_model, tam_metrics,
)
from femupdate.reduction import reducer as reducer_mod
from femupdate.reduction.criteria import ReductionCriteriaWarning
from femupdate.reduction.metrics import orthogonality
from femupdate.reduction.superelement import lin_beam, split_structure

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ch():
    return chain([1000.0, 2000.0, 1500.0, 800.0, 1200.0, 900.0], [1.0, 1.5, 2.0, 1.0, 1.2, 0.8])


@pytest.fixture(scope="module")
def frame():
    return frame_lattice(3, 2, 4).build()  # 108 dofs, 3 storey moduli


def _dense(model, values=None):
    return model.K(values).toarray(), model.M(values).toarray()


def _parts(model, keep):
    ia = model.dof_index(keep)
    io = np.setdiff1d(np.arange(model.n_dofs), ia)
    return ia, io


# ------------------------------------------------------------------------------- Guyan
def test_guyan_is_eq38_and_eq40(frame):
    keep = ["8:z", "11:x", "20:y", "13:x", "24:rz", "9:y"]  # any order: the reduced model follows it
    K, M = _dense(frame)
    ia, io = _parts(frame, keep)
    Kaa, Kao, Koo = K[np.ix_(ia, ia)], K[np.ix_(ia, io)], K[np.ix_(io, io)]
    Maa, Mao, Moo = M[np.ix_(ia, ia)], M[np.ix_(ia, io)], M[np.ix_(io, io)]
    Koi = np.linalg.inv(Koo)
    KG = Kaa - Kao @ Koi @ Kao.T  # eq. 38
    MG = Maa - Kao @ Koi @ Mao.T - Mao @ Koi @ Kao.T + Kao @ Koi @ Moo @ Koi @ Kao.T  # eq. 40
    t = guyan(frame, keep)
    assert t.T.shape == (frame.n_dofs, 6) and t.keep == tuple(keep)
    np.testing.assert_allclose(t.T[ia], np.eye(6), atol=0)
    Kr, Mr = reduced_matrices(frame, t)
    np.testing.assert_allclose(Kr, KG, rtol=1e-9, atol=1e-9 * np.abs(KG).max())
    np.testing.assert_allclose(Mr, MG, rtol=1e-9, atol=1e-9 * np.abs(MG).max())
    r = reduce(frame, t)
    assert r.dofs == tuple(keep) and r.parameter_names == frame.parameter_names
    np.testing.assert_allclose(r.K().toarray(), KG, rtol=1e-9, atol=1e-9 * np.abs(KG).max())


def test_guyan_is_exact_for_static_loads(frame):
    keep = ["11:x", "13:y", "20:z", "24:x"]
    K, _ = _dense(frame)
    ia, _ = _parts(frame, keep)
    f = np.zeros(frame.n_dofs)
    f[ia] = [1.0, -2.0, 0.5, 3.0]
    u = np.linalg.solve(K, f)
    t = guyan(frame, keep)
    Kr, _ = reduced_matrices(frame, t)
    ua = np.linalg.solve(Kr, f[ia])
    np.testing.assert_allclose(ua, u[ia], rtol=1e-9)
    np.testing.assert_allclose(t.expand(ua), u, rtol=1e-8, atol=1e-12 * np.abs(u).max())


def test_guyan_is_exact_when_the_omitted_dofs_are_massless():
    # masses at 1 and 3; dof 2 massless between springs k2, k3: k2 and k3 in series (closed form)
    k1, k2, k3, m1, m3 = 400.0, 300.0, 600.0, 2.0, 3.0
    s = Structure("massless middle")
    s.spring(["1:x"], k=k1); s.spring(["1:x", "2:x"], k=k2); s.spring(["2:x", "3:x"], k=k3)
    s.mass(["1:x"], m=m1); s.mass(["3:x"], m=m3)
    model = s.build()
    t = guyan(model, ["1:x", "3:x"])
    Kr, Mr = reduced_matrices(model, t)
    ks = k2 * k3 / (k2 + k3)
    Kc = np.array([[k1 + ks, -ks], [-ks, ks]])
    lam_exact = sla.eigh(Kc, np.diag([m1, m3]), eigvals_only=True)
    np.testing.assert_allclose(reduced_eigenvalues(Kr, Mr), lam_exact, rtol=1e-12)


def test_reduced_model_is_affine_with_T_frozen_and_exact_only_at_its_values(frame):
    keep = ["11:x", "13:y", "20:z", "24:x", "17:y"]
    t = guyan(frame, keep)
    r = reduce(frame, t)
    p = frame.values * np.array([1.3, 0.7, 1.1])
    K, M = _dense(frame, p)
    np.testing.assert_allclose(r.K(p).toarray(), t.T.T @ K @ t.T, rtol=1e-9, atol=1e-6 * np.abs(K).max())
    np.testing.assert_allclose(r.M(p).toarray(), t.T.T @ M @ t.T, rtol=1e-9, atol=1e-9 * np.abs(M).max())
    # ...but a Guyan T rebuilt at p differs: the frozen one is exact only at t.values
    K_new, _ = reduced_matrices(frame, guyan(frame, keep, values=p))
    assert np.max(np.abs(K_new - r.K(p).toarray())) > 1e-6 * np.abs(K_new).max()


def test_k_oo_is_factorised_once_for_every_method(frame, monkeypatch):
    calls = []
    real = reducer_mod.factorize
    monkeypatch.setattr(reducer_mod, "factorize", lambda A, **kw: calls.append(A.shape) or real(A, **kw))
    red = Reducer(frame, ["11:x", "13:y", "20:z", "24:x", "17:y", "8:z"])
    red.guyan(); red.irs(); red.kammer_hybrid(3)
    reduction_criteria(frame, red.keep, reducer=red, warn=False)
    expand_red = red.guyan().T  # cached
    assert len(calls) == 1 and expand_red.shape[1] == 6


# ------------------------------------------------------------------------------- IRS
def test_irs_equals_ocallahan_dense_formula_and_beats_guyan(ch):
    keep = ["2:x", "4:x", "6:x"]
    K, M = _dense(ch)
    ia, io = _parts(ch, keep)
    t_g = guyan(ch, keep)
    KG, MG = reduced_matrices(ch, t_g)
    S = np.zeros_like(K)
    S[np.ix_(io, io)] = np.linalg.inv(K[np.ix_(io, io)])
    T_ref = t_g.T + S @ M @ t_g.T @ np.linalg.inv(MG) @ KG  # O'Callahan (1989)
    t = irs(ch, keep)
    np.testing.assert_allclose(t.T, T_ref, rtol=1e-10, atol=1e-12)
    lam = model_modes(ch).eigenvalues[:3]
    err_g = np.abs(reduced_eigenvalues(KG, MG) / lam - 1)
    err_i = np.abs(reduced_eigenvalues(*reduced_matrices(ch, t)) / lam - 1)
    assert np.all(err_i < err_g) and err_i[0] < 1e-3
    # eq. 42 as printed (minus sign, M_aa^-1 K_aa) is far worse than both
    from femupdate.paper.reduction_sections import irs_as_printed

    Tp = irs_as_printed(Reducer(ch, keep))
    err_p = np.abs(reduced_eigenvalues(Tp.T @ K @ Tp, Tp.T @ M @ Tp) / lam - 1)
    assert err_p.max() > 10 * err_g.max()


# ------------------------------------------------------------------------------- modal, hybrid, SEREP
def test_modal_hybrid_serep_reproduce_their_target_modes(frame):
    keep = ["11:x", "13:y", "20:z", "24:x", "17:y", "8:z", "21:x", "16:y"]
    full = model_modes(frame, n_modes=8)
    ia, _ = _parts(frame, keep)
    for m in (3, 5):
        for builder in (kammer_modal, kammer_hybrid, serep):
            t = builder(frame, keep, n_modes=m)
            lam = reduced_eigenvalues(*reduced_matrices(frame, t))
            np.testing.assert_allclose(lam[:m], full.eigenvalues[:m], rtol=1e-9)
            # T maps the retained partition of each target mode to the whole mode
            np.testing.assert_allclose(t.T @ full.shapes[ia, :m], full.shapes[:, :m], atol=1e-8 * np.abs(full.shapes).max())
        assert np.allclose(kammer_modal(frame, keep, n_modes=m).T[ia], np.eye(8))  # eq. 43: identity on the a-set
    a = len(keep)
    t_mod, t_hyb, t_ser = (b(frame, keep, n_modes=a).T for b in (kammer_modal, kammer_hybrid, serep))
    np.testing.assert_allclose(t_mod, t_ser, atol=1e-8 * np.abs(t_ser).max())  # m = a: modal TAM = SEREP
    np.testing.assert_allclose(t_hyb, t_mod, atol=1e-7 * np.abs(t_mod).max())  # and the hybrid = modal
    lam = reduced_eigenvalues(*reduced_matrices(frame, serep(frame, keep, n_modes=3)))
    assert lam.size == 3  # SEREP with m < a: rank-m reduced matrices, m eigenvalues


def test_hybrid_differs_from_modal_off_the_targets(ch):
    keep = ["1:x", "3:x", "4:x", "6:x"]
    t_m, t_h, t_g = kammer_modal(ch, keep, n_modes=2), kammer_hybrid(ch, keep, n_modes=2), guyan(ch, keep)
    full = model_modes(ch)
    ia, _ = _parts(ch, keep)
    # a retained vector M_mod-orthogonal to the targets is mapped as by Guyan
    Mm = reduced_matrices(ch, t_m)[1]
    phi_a = full.shapes[ia, :2]
    v = np.linalg.svd((Mm @ phi_a).T)[2][-1]
    np.testing.assert_allclose(t_h.T @ v, t_g.T @ v, atol=1e-10)
    assert np.max(np.abs(t_m.T @ v - t_g.T @ v)) > 1e-3


# ------------------------------------------------------------------------------- bad input
def test_bad_keep_sets(ch):
    with pytest.raises(InputError, match="not in the model: 9:x"):
        guyan(ch, ["1:x", "9:x"])
    with pytest.raises(InputError, match="listed twice: 2:x"):
        guyan(ch, ["2:x", "2:x"])
    with pytest.raises(InputError, match="no dofs"):
        guyan(ch, [])
    big = [f"{i}:x" for i in range(1, 7)]
    assert guyan(ch, big).T.shape == (6, 6)  # all kept: the identity
    with pytest.raises(InputError, match="7 dofs to retain but the model has only 6"):
        Reducer(chain([1.0] * 7, [1.0] * 7), [f"{i}:x" for i in range(1, 8)]) and Reducer(ch, big + ["1:y"])


def test_more_kept_than_model_dofs_named():
    m = chain([1.0, 1.0], [1.0, 1.0])
    with pytest.raises(InputError, match="3 dofs to retain but the model has only 2"):
        Reducer(m, ["1:x", "2:x", "1:y"])


def test_singular_omitted_partition_names_the_mechanism():
    # dofs 3, 4 hang from dof 2 only; keeping 2 leaves 3-4 free-floating: a mechanism
    s = Structure("floating pair")
    s.spring(["1:x"], k=100.0); s.spring(["1:x", "2:x"], k=100.0)
    s.spring(["3:x", "4:x"], k=50.0); s.spring(["2:x", "5:x"], k=70.0)
    for d in ("1:x", "2:x", "3:x", "4:x", "5:x"):
        s.mass([d], m=1.0)
    model = s.build()
    with pytest.raises(InputError, match=r"K_oo is singular.*3:x, 4:x.*mechanism") as exc:
        guyan(model, ["1:x", "2:x"])
    assert "5:x" not in str(exc.value)
    with pytest.raises(InputError, match="3:x, 4:x"):
        expand(model, ["1:x", "2:x"], np.ones(2), method="guyan", warn_validation=False)


def test_modal_needs_at_most_as_many_modes_as_kept_dofs_and_distinct_modes(ch):
    with pytest.raises(InputError, match="4 modes for 3 retained dofs"):
        kammer_modal(ch, ["1:x", "3:x", "5:x"], n_modes=4)
    with pytest.raises(InputError, match="4 modes for 3 retained dofs"):
        kammer_hybrid(ch, ["1:x", "3:x", "5:x"], n_modes=4)
    # symmetric star: the antisymmetric arm mode does not move the hub dofs
    s = Structure("star")
    s.spring(["1:x"], k=1e4); s.spring(["1:x", "2:x"], k=1e4)
    s.spring(["2:x", "3:x"], k=10.0); s.spring(["2:x", "4:x"], k=10.0)
    for d in ("1:x", "2:x", "3:x", "4:x"):
        s.mass([d], m=1.0)
    star = s.build()
    with pytest.raises(InputError, match="do not distinguish the 2 modes"):
        kammer_modal(star, ["1:x", "2:x"], n_modes=2)


# ------------------------------------------------------------------------------- expansion (the contract)
def test_expand_contract_serep_recovers_the_models_own_modes(frame):
    measured = ["11:x", "13:y", "20:z", "24:x", "17:y", "8:z"]
    fm = model_modes(frame, n_modes=4)
    with pytest.warns(ExpansionBiasWarning, match="biased for validating"):
        e = expand(frame, measured, fm.at(measured) * 3.0)
    assert isinstance(e, ExpandedShapes) and e.dofs == frame.dofs and e.method == "serep"
    assert e.shapes.shape == (frame.n_dofs, 4) and e.n_modes == 4 and e.error.shape == (4,)
    np.testing.assert_allclose(e.shapes, 3.0 * fm.shapes, atol=1e-8 * np.abs(fm.shapes).max())
    assert np.all(e.error < 1e-10)
    assert issubclass(ExpansionBiasWarning, UserWarning)


def test_expand_guyan_irs_keep_measured_values_and_serep_reports_misfit(frame):
    measured = ["11:x", "13:y", "20:z", "24:x", "17:y", "8:z"]
    rng = np.random.default_rng(3)
    X = rng.standard_normal((6, 2)) + 1j * rng.standard_normal((6, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # warn_validation=False: no warning at all
        g = expand(frame, measured, X, method="guyan", warn_validation=False)
        i = expand(frame, measured, X, method="irs", warn_validation=False)
        s = expand(frame, measured, X, method="serep", n_modes=2, warn_validation=False)
    np.testing.assert_allclose(g.shapes, guyan(frame, measured).T @ X, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(i.shapes, irs(frame, measured).T @ X, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(g.at(measured), X, atol=1e-12)
    assert np.all(g.error < 1e-12) and np.all(i.error < 1e-12)
    # SEREP with 2 modes: the least-squares fit, and its misfit is the error
    phi = model_modes(frame, n_modes=2)
    fit = phi.at(measured) @ np.linalg.lstsq(phi.at(measured), X, rcond=None)[0]
    np.testing.assert_allclose(s.at(measured), fit, atol=1e-10)
    np.testing.assert_allclose(s.error, np.linalg.norm(fit - X, axis=0) / np.linalg.norm(X, axis=0), rtol=1e-8)


def test_expand_bad_input(ch):
    with pytest.raises(InputError, match="shape"):
        expand(ch, ["1:x", "2:x"], np.ones((3, 1)), warn_validation=False)
    with pytest.raises(InputError, match="NaN"):
        expand(ch, ["1:x", "2:x"], np.array([1.0, np.nan]), warn_validation=False)
    with pytest.raises(InputError, match="unknown method"):
        expand(ch, ["1:x"], np.ones(1), method="modal", warn_validation=False)
    with pytest.raises(InputError, match="not in the model: 8:x"):
        expand(ch, ["1:x", "8:x"], np.ones(2), warn_validation=False)
    with pytest.raises(InputError, match="3 modes for 2 retained"):
        expand(ch, ["1:x", "2:x"], np.ones((2, 1)), n_modes=3, warn_validation=False)
    with pytest.raises(InputError, match="zero at every measured dof"):
        expand(ch, ["1:x", "2:x"], np.zeros((2, 1)), warn_validation=False)


# ------------------------------------------------------------------------------- criteria, metrics, selection
def test_criteria_omitted_eigenvalues_are_the_grounded_structure(ch):
    keep = ["2:x", "5:x"]
    c = reduction_criteria(ch, keep, warn=False)
    s = Structure("grounded")  # the same chain with the kept dofs supported: a second route
    k, m = [1000.0, 2000.0, 1500.0, 800.0, 1200.0, 900.0], [1.0, 1.5, 2.0, 1.0, 1.2, 0.8]
    s.spring(["1:x"], k=k[0])
    for i in range(1, 6):
        s.spring([f"{i}:x", f"{i + 1}:x"], k=k[i])
    for i in range(6):
        s.mass([f"{i + 1}:x"], m=m[i])
    s.support(keep)
    lam = model_modes(s.build()).eigenvalues
    np.testing.assert_allclose(c.omitted_eigenvalues, lam[: c.omitted_eigenvalues.size], rtol=1e-10)
    np.testing.assert_allclose(c.grounded_frequency_hz, np.sqrt(lam[0]) / (2 * np.pi), rtol=1e-10)
    KG, MG = reduced_matrices(ch, guyan(ch, keep))
    np.testing.assert_allclose(c.retained_eigenvalues, reduced_eigenvalues(KG, MG), rtol=1e-12)
    with pytest.warns(ReductionCriteriaWarning, match="Larsson & Sas"):
        bad = reduction_criteria(ch, keep, f_max_hz=2 * c.grounded_frequency_hz)
    assert not bad.ok_larsson_sas


def test_criteria_sparse_path_matches_dense(frame, monkeypatch):
    keep = ["11:x", "13:y", "20:z", "24:x"]
    dense = reduction_criteria(frame, keep, warn=False, k_omitted=4)
    from femupdate.reduction import criteria

    monkeypatch.setattr(criteria, "DENSE_LIMIT", 10)
    sparse = reduction_criteria(frame, keep, warn=False, k_omitted=4)
    np.testing.assert_allclose(sparse.omitted_eigenvalues, dense.omitted_eigenvalues, rtol=1e-8)


def test_tam_metrics_and_orthogonality(frame):
    keep = ["11:x", "13:y", "20:z", "24:x", "17:y", "8:z", "21:x", "16:y"]
    fm = model_modes(frame, n_modes=8)
    t = kammer_modal(frame, keep, n_modes=4)
    r = tam_metrics(frame, t, n_modes=4, test_shapes=fm.at(keep)[:, :4], full_modes=fm)
    assert r.max_frequency_error < 1e-9 and r.min_mac > 1 - 1e-9 and r.pseudo_max_offdiag < 1e-9
    assert r.self_max_offdiag < 1e-9 and r.cross_min_diag > 1 - 1e-9
    g = tam_metrics(frame, guyan(frame, keep), n_modes=4, full_modes=fm)
    assert g.max_frequency_error > 1e-4 and g.self_orthogonality is None
    A = np.random.default_rng(0).standard_normal((5, 3))
    Mx = np.diag([1.0, 2.0, 3.0, 4.0, 5.0])
    O = orthogonality(A, A, Mx)
    np.testing.assert_allclose(np.diag(O), 1.0)
    np.testing.assert_allclose(O[0, 1], A[:, 0] @ Mx @ A[:, 1] / np.sqrt((A[:, 0] @ Mx @ A[:, 0]) * (A[:, 1] @ Mx @ A[:, 1])))


def test_mass_fraction_and_effective_independence(ch, frame):
    np.testing.assert_allclose(mass_fraction(ch, ["1:x", "3:x"]), 3.0 / 7.5, rtol=1e-12)
    r = effective_independence(frame, n_sensors=6, n_modes=4)
    assert len(r.selected) == 6 and len(r.removed) == len([d for d in frame.dofs if d.split(":")[1] in "xyz"]) - 6
    assert np.all(np.diff(r.determinant) <= 1e-12)  # the Fisher determinant only decreases
    phi = model_modes(frame, n_modes=4).at(r.selected)
    phi = phi / np.linalg.norm(model_modes(frame, n_modes=4).at([d for d in frame.dofs if d.split(":")[1] in "xyz"]), axis=0)
    E = np.diag(phi @ np.linalg.inv(phi.T @ phi) @ phi.T)
    np.testing.assert_allclose(r.efi, E, rtol=1e-8)
    with pytest.raises(InputError, match="n_sensors"):
        effective_independence(frame, n_sensors=3, n_modes=4)


# ------------------------------------------------------------------------------- super-elements
def test_lin_beam_superelements_are_exact_condensation_at_every_parameter_value():
    s, key, keep = lin_beam()
    full = s.build()
    se, info = superelement_model(s, key, keep)
    assert (full.n_dofs, se.n_dofs, len(info), len(se.parameters)) == (102, 52, 25, 25)
    assert se.dofs == tuple(keep)
    p = full.values * np.linspace(0.6, 1.8, 25)
    t = guyan(full, keep, values=p)  # a global Guyan rebuilt at p: the same model (T independent of p)
    Kp, Mp = reduced_matrices(full, t)
    np.testing.assert_allclose(se.K(p).toarray(), Kp, rtol=1e-9, atol=1e-9 * np.abs(Kp).max())
    np.testing.assert_allclose(se.M(p).toarray(), Mp, rtol=1e-9, atol=1e-9 * np.abs(Mp).max())
    K = se.K().toarray()
    i, j = np.nonzero(K)
    assert np.max(np.abs(i - j)) <= 3  # banded: each super-element couples its two end nodes only
    lam_full = model_modes(full, p, n_modes=12).eigenvalues[2:]
    lam_se = model_modes(se, p, n_modes=12).eigenvalues[2:]
    assert np.max(np.abs(lam_se / lam_full - 1)) < 5e-3


def test_superelement_errors():
    s, key, keep = lin_beam(n_elements=4)
    with pytest.raises(InputError, match="shared by several super-elements"):
        superelement_model(s, key, [k for k in keep if not k.startswith("3:")])
    with pytest.raises(InputError, match="not in the model: 99:y"):
        superelement_model(s, key, keep + ["99:y"])
    parts = split_structure(s, key)
    a, b = (p.build() for p in parts.values())
    b2 = b.with_values({b.parameter_names[0]: 1.0})
    assert assemble([a, b]).n_dofs == 10
    from dataclasses import replace

    with pytest.raises(InputError, match="declared differently"):
        assemble([a, replace(b2, parameters=(replace(b2.parameters[0], name=a.parameter_names[0]),))])


# ------------------------------------------------------------------------------- CLI
def _write_model(tmp_path):
    K2 = '"k2"'
    text = "\n".join(
        ["[model]", 'name = "chain"', "[parameters.k1]", "value = 1000.0", "[parameters.k2]", "value = 2000.0"]
        + ['[[element]]\ntype = "spring"\ndofs = ["1:x"]\nk = "k1"']
        + [f'[[element]]\ntype = "spring"\ndofs = ["{i}:x", "{i + 1}:x"]\nk = {K2 if i == 1 else 1500.0}' for i in range(1, 5)]
        + [f'[[element]]\ntype = "mass"\ndofs = ["{i}:x"]\nm = {1.0 + 0.25 * i}' for i in range(1, 6)])
    p = tmp_path / "chain.toml"
    p.write_text(text + "\n")
    return p


def test_cli_reduce_json(tmp_path, capsys):
    mp = _write_model(tmp_path)
    out = tmp_path / "r.json"
    with pytest.raises(SystemExit) as e:
        main(["reduce", str(mp), "--keep", "2:x,5:x", "--method", "irs", "--json", str(out)])
    assert e.value.code == 0
    r = json.loads(out.read_text())
    assert r["method"] == "irs" and r["keep"] == ["2:x", "5:x"]
    assert len(r["frequencies_hz"]["full"]) == 2 and len(r["frequencies_hz"]["reduced"]) == 2
    assert np.array(r["K"]).shape == (2, 2) and np.array(r["M"]).shape == (2, 2)
    assert set(r["frequency_error"]) == {"guyan", "irs", "modal", "hybrid", "serep"}
    assert abs(r["frequency_error"]["serep"][0]) < 1e-12 < abs(r["frequency_error"]["guyan"][0])
    assert "frequency error per method" in capsys.readouterr().out


@pytest.mark.parametrize("args, msg", [
    (["--keep", "2:x,7:x"], "not in the model: 7:x"),
    (["--keep", "1:x,2:x,3:x,4:x,5:x,1:y"], "6 dofs to retain but the model has only 5"),
    (["--keep", "2:x", "--method", "hybrid", "--n-modes", "2"], "2 modes for 1 retained dofs"),
    (["--keep", ","], "no dofs given"),
])
def test_cli_reduce_bad_input(tmp_path, capsys, args, msg):
    mp = _write_model(tmp_path)
    with pytest.raises(SystemExit) as e:
        main(["reduce", str(mp), *args])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert msg in err and "Traceback" not in err


# ------------------------------------------------------------------------------- paper sections, benchmark
def test_paper_sections(tmp_path):
    from femupdate.paper.reduction_sections import reduction_truss, superelement_beam

    t = reduction_truss(tmp_path, figures=False, seeds=2)
    assert t["geometry"]["n_dofs"] == 1020 and 0.04 <= t["retained_mass_fraction"] <= 0.06  # Tan's ~5 %
    assert t["accuracy_ranking_matches"] is True and t["irs_at_least_as_robust_as_guyan"] is True
    # Tan's point: the modal TAM's robustness degrades with the model error, the physical reductions' far less
    g = t["self_orthogonality_growth"]["with_local"]
    assert g["modal"] > 2 * max(g["guyan"], g["irs"])
    assert t["comparison"] in ("agree", "differ-explained") and t["explanation"]
    e = t["eq42_max_frequency_error_first5"]
    assert e["irs_corrected"] < e["guyan"] < e["irs_as_printed"]
    b = superelement_beam(tmp_path, figures=True)
    assert b["agrees_with_paper"] is True and (b["full_dofs"], b["reduced_dofs"]) == (102, 52)
    assert b["direct_on_reduced"]["data_consistent_with_reduced_model"]["max_parameter_error"] < 1e-8
    assert b["direct_on_reduced"]["data_from_full_structure"]["max_parameter_error"] > 1e-4
    assert (tmp_path / b["figure"]).stat().st_size > 1000


def test_bench_reduction_quick_runs(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_reduction.py"), "--quick", "--output", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    r = json.loads(out.read_text())
    assert r["check"]["ok"] and r["model"]["n_keep"] <= 200 and r["ratio"]["guyan_over_limit"] > 0
