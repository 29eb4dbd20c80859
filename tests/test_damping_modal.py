"""Modal damping ratios as parameters (issue 31, item 1: ratios per mode or group of modes, acting
in the real modal coordinates): complex modes, receptances, exact sensitivities, updating, and
the ``[damping]`` table's ``modal`` entry with its bad input.

References: closed forms (λ_r = −ζ_r ω_r + i ω_r √(1 − ζ_r²) of a model with modal ratios only,
and the modal superposition Σ φ_r φ_rᵀ f / (ω_r² − ω² + 2iζ_r ω_r ω) of its receptances, from the
undamped modes by SciPy); central differences for every derivative, with physical damping (a
damper, a loss factor) beside the ratios so that the modal coordinates couple; recovery of the
truth from noise-free data simulated by the model itself.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg as la

import femupdate
from femupdate._errors import InputError
from femupdate.damping import (DampedModel, Damper, LossFactor, complex_modes, complex_sensitivities, fit_damping,
                               load_damped_model)
from femupdate.damping.frf import damped_response
from femupdate.examples import truss_model_toml
from femupdate.model import Parameter
from femupdate.testdata import FRFData, MeasuredMode, TestData
from test_damping_update import DOFS, _truss

RATIOS = (Parameter("z1", 0.02, (0.0, 0.5)), Parameter("z23", 0.03, (0.0, 0.5)))


@pytest.fixture(scope="module")
def truss():
    return _truss()


def _modal(truss, physical: bool = True) -> DampedModel:
    """The truss with modal ratios z1 (mode 1), z23 (modes 2 and 3, a group) and two fixed ones;
    with ``physical`` also a damper c1 and a loss factor on E (C and D couple the modal coordinates)."""
    extra = (Parameter("c1", 400.0, (0.0, 1e4)), Parameter("eta", 0.01, (0.0, 0.5))) if physical else ()
    return DampedModel(truss.model, RATIOS + extra, dampers=(Damper(("4:x", "104:y"), "c1"),) if physical else (),
                       losses=(LossFactor("eta", "E"),) if physical else (), modal=("z1", "z23", "z23", 0.015, 0.01))


def test_modal_ratios_only_closed_forms(truss):
    dm = _modal(truss, physical=False)
    K, M = truss.model.K().toarray(), truss.model.M().toarray()
    w2, Phi = la.eigh(K, M)
    w = np.sqrt(w2[:5])
    zeta = np.array([0.02, 0.03, 0.03, 0.015, 0.01])
    cm = complex_modes(dm)
    np.testing.assert_allclose(cm.eigenvalues, -zeta * w + 1j * w * np.sqrt(1 - zeta ** 2), rtol=1e-12)
    # d lambda / d zeta = -w - i w zeta / sqrt(1 - zeta^2), summed over a group's modes
    cs = complex_sensitivities(dm, cm, None, ["z1", "z23"])
    d = -w - 1j * w * zeta / np.sqrt(1 - zeta ** 2)
    np.testing.assert_allclose(cs.d_eigenvalues[:, 0], [d[0], 0, 0, 0, 0], atol=1e-12 * abs(d).max())
    np.testing.assert_allclose(cs.d_eigenvalues[:, 1], [0, d[1], d[2], 0, 0], atol=1e-12 * abs(d).max())
    np.testing.assert_allclose(cs.d_damping_ratios, [[1, 0], [0, 1], [0, 1], [0, 0], [0, 0]], atol=1e-12)
    # receptances: modal superposition of the five modes with their ratios
    om = 2 * np.pi * np.array([10.0, 46.0, 120.0, 201.0, 400.0])
    f = np.zeros(truss.n_dofs)
    f[truss.model.dof_index(["4:y"])[0]] = 1.0
    S = truss.model.dof_index(list(DOFS))
    x, _ = damped_response(dm, om, {"4:y": 1.0}, DOFS)
    ref = sum(np.outer(1.0 / (w[r] ** 2 - om ** 2 + 2j * zeta[r] * w[r] * om), Phi[S, r] * (Phi[:, r] @ f))
              for r in range(5))
    np.testing.assert_allclose(x, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def _central(fun, p, j, h):
    up, dn = p.copy(), p.copy()
    up[j] += h
    dn[j] -= h
    return (fun(up) - fun(dn)) / (2 * h)


def test_exact_sensitivities_to_ratios_stiffness_damper_and_loss_factor_match_central_differences(truss):
    dm = _modal(truss)
    names = list(dm.parameter_names)
    assert names == ["E", "z1", "z23", "c1", "eta"]
    p = dm.resolve(None)
    cm = complex_modes(dm)
    assert cm.modal and cm.n_modes == 5
    cs = complex_sensitivities(dm, cm, p, names, vectors=True)
    om = 2 * np.pi * np.linspace(20.0, 300.0, 15)
    x, dx = damped_response(dm, om, {"4:y": 1.0}, DOFS, p, names)
    for j, name in enumerate(names):
        h = 1e-6 * abs(p[j])
        dl = _central(lambda q: complex_modes(dm, values=q).eigenvalues, p, j, h)
        ds = _central(lambda q: complex_modes(dm, values=q).shapes, p, j, h)
        dr = _central(lambda q: damped_response(dm, om, {"4:y": 1.0}, DOFS, q)[0], p, j, h)
        assert np.max(np.abs(dl - cs.d_eigenvalues[:, j])) < 1e-6 * np.max(np.abs(cs.d_eigenvalues[:, j])), name
        assert np.max(np.abs(ds - cs.d_shapes[:, :, j])) < 1e-5 * np.max(np.abs(cs.d_shapes[:, :, j])), name
        assert np.max(np.abs(dr - dx[:, :, j])) < 1e-6 * np.max(np.abs(dx[:, :, j])), name


def _data(dm: DampedModel, n: int = 4) -> TestData:
    cm = complex_modes(dm, n_modes=n)
    idx = dm.model.dof_index(list(DOFS))
    return TestData(modes=tuple(MeasuredMode(float(abs(lam)) ** 2, DOFS, cm.shapes[idx, r], damping_ratio=float(z))
                                for r, (lam, z) in enumerate(zip(cm.eigenvalues, cm.damping_ratios))))


def test_update_recovers_modal_ratios_and_stiffness_from_complex_modes_and_from_frfs(truss):
    dm = _modal(truss)
    truth = dict(zip(dm.parameter_names, dm.resolve(None)))
    start = dm.with_values({"E": 6.3e10, "z1": 0.05, "z23": 0.01, "c1": 250.0})
    res = femupdate.update(start, _data(dm), params=["E", "z1", "z23", "c1"])
    assert res.success and res.damping["parameters"] == ["z1", "z23", "c1"]
    for name in ("E", "z1", "z23", "c1"):
        assert res.parameters[name] == pytest.approx(truth[name], rel=1e-6), name
    om = 2 * np.pi * np.linspace(20.0, 300.0, 41)
    X, _ = damped_response(dm, om, {"4:y": 1.0}, DOFS[4:])
    fr = femupdate.updating.frf_update(dm.with_values({"z1": 0.05, "z23": 0.01, "c1": 250.0}), TestData(frf=FRFData(om, {"4:y": 1.0}, DOFS[4:], X)),
                                       params=["z1", "z23", "c1"])
    assert fr.success and min(fr.frac.values()) > 1 - 1e-10
    assert not any("FRF lines reach" in n for n in fr.notes)  # 300 Hz: below the fifth mode (335 Hz)
    for name in ("z1", "z23", "c1"):
        assert fr.parameters[name] == pytest.approx(truth[name], rel=1e-6), name
    # fit_damping (complex eigenvalues paired in order) takes the ratio parameters too
    fit = fit_damping(dm.with_values({"z1": 0.05, "z23": 0.01, "c1": 100.0}), complex_modes(dm).eigenvalues[:4],
                      ["z1", "z23", "c1"])
    for name in ("z1", "z23", "c1"):
        assert fit.values[name] == pytest.approx(truth[name], rel=1e-9), name


def _model_file(tmp_path, modal: str, params: str = "") -> object:
    p = tmp_path / "m.toml"
    p.write_text(truss_model_toml() + f"\n[damping]\nmodal = {modal}\n" + params)
    return p


def test_modal_table_syntax_groups_and_ratio_parameters(tmp_path):
    params = "[damping.parameters.z23]\nvalue = 0.03\n[damping.parameters.z1]\nvalue = 0.02\nbounds = [0.0, 0.5]\n"
    a = load_damped_model(_model_file(tmp_path, '{ "1" = "z1", "2-3" = "z23", "4" = 0.015 }', params))
    b = load_damped_model(_model_file(tmp_path, '["z1", "z23", "z23", 0.015]', params))
    assert a.modal == b.modal == ("z1", "z23", "z23", 0.015)
    np.testing.assert_allclose(complex_modes(a).damping_ratios, [0.02, 0.03, 0.03, 0.015], rtol=1e-10)
    # a ratio parameter's upper bound is at most 1 (critical damping)
    assert dict((q.name, q.bounds) for q in a.parameters) == {"z23": (0.0, 1.0), "z1": (0.0, 0.5)}


BAD = {
    "negative ratio": ("[-0.01, 0.02]", "", "modal damping ratio of mode 1 = -0.01 must be a finite damping ratio >= 0"),
    "ratio of 1": ("[0.02, 1.0]", "", "modal damping ratio of mode 2 = 1 is critical damping"),
    "percent": ("[2.0, 3.0]", "", "modal damping ratio of mode 1 = 2.0 is above 1: damping ratios are fractions of "
                "critical damping (2 % is 0.02); it looks like a percentage, write 0.02"),
    "percent parameter": ('["z"]', "[damping.parameters.z]\nvalue = 2.0\n",
                          "damping parameter 'z' (a modal damping ratio) = 2.0 is above 1"),
    "unknown mode": ('{ "0" = 0.02 }', "", "modal: modes '0' are not modes of the model (modes 1 to 12"),
    "mode beyond the dofs": ('{ "1-99" = 0.02 }', "", "modal: modes '1-99' are not modes of the model"),
    "not a mode": ('{ "first" = 0.02 }', "", "modal: 'first' is not a mode or a range of modes"),
    "half a range": ('{ "1-" = 0.02 }', "", "modal: '1-' is not a mode or a range of modes"),
    "a gap": ('{ "1" = 0.02, "3" = 0.02 }', "", "modal: mode(s) 2 have no ratio"),
    "mode twice": ('{ "1-2" = 0.02, "2" = 0.03 }', "", "modal: mode 2 is given twice ('1-2' and '2')"),
    "unknown group": ('{ "1-2" = "zz" }', "", "modal: modes 1-2 = 'zz' is not a damping parameter"),
    "unknown name in the list": ('["zz"]', "", "modal damping ratio of mode 1 = 'zz' is not a damping parameter"),
    "more ratios than dofs": (str([0.01] * 13), "", "13 modal damping ratios but model"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_modal_ratios_one_message_exit_2(tmp_path, capsys, case):
    from femupdate.cli import main

    modal, params, message = BAD[case]
    path = _model_file(tmp_path, modal, params)
    with pytest.raises(SystemExit) as info:
        main(["complex-modes", str(path)])
    out, err = capsys.readouterr()
    assert info.value.code == 2, out + err
    assert message in err and str(path) in err and "Traceback" not in err, err
    assert err.strip().count("\n") == 0, err
    with pytest.raises(InputError):
        load_damped_model(path)


def test_update_cli_with_modal_ratio_parameters_from_a_data_file(tmp_path, capsys, truss):
    dm = _modal(truss, physical=False)
    data = _data(dm, 4)
    modes = [{"frequency_hz": float(np.sqrt(m.eigenvalue) / (2 * np.pi)), "damping_ratio": m.damping_ratio,
              "shape": {d: [float(v.real), float(v.imag)] for d, v in zip(m.dofs, m.shape)}} for m in data.modes]
    (tmp_path / "t.json").write_text(json.dumps({"modes": modes}))
    params = ("[damping.parameters.z1]\nvalue = 0.05\nbounds = [0.0, 0.5]\n"
              "[damping.parameters.z23]\nvalue = 0.01\nbounds = [0.0, 0.5]\n")
    path = _model_file(tmp_path, '{ "1" = "z1", "2-3" = "z23", "4" = 0.015, "5" = 0.01 }', params)
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(["update", str(path), str(tmp_path / "t.json"), "--params", "z1,z23", "--json", str(tmp_path / "r.json")])
    out, err = capsys.readouterr()
    assert info.value.code == 0, out + err
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["parameters"]["z1"] == pytest.approx(0.02, rel=1e-6) and r["parameters"]["z23"] == pytest.approx(0.03, rel=1e-6)
    assert "damping parameters updated: z1 = 0.02" in out


def test_frf_lines_above_the_modes_with_ratios_are_said(truss):
    dm = _modal(truss)
    om = 2 * np.pi * np.linspace(20.0, 400.0, 21)
    X, _ = damped_response(dm, om, {"4:y": 1.0}, DOFS[4:])
    res = femupdate.updating.frf_update(dm, TestData(frf=FRFData(om, {"4:y": 1.0}, DOFS[4:], X)), params=["z1"],
                                        max_nfev=2)
    assert any("the FRF lines reach 400 Hz, above the highest of the 5 modes with modal damping ratios (334.7 Hz"
               in n for n in res.notes), res.notes


def test_no_truncation_note_when_every_mode_has_a_ratio(tmp_path):
    """A 2-dof chain with ratios for both its modes: the receptances are the full modal
    superposition (closed form below), so FRF lines above the top mode leave nothing out and no
    note says they do (it once did); the update recovers k2 and the ratios."""
    K1, K2, M1, M2, Z = 2000.0, 1500.0, 2.0, 1.0, (0.02, 0.05)
    p = tmp_path / "chain.toml"
    p.write_text(f"""[parameters.k2]
value = {K2}
bounds = [100.0, 1.0e4]

[[element]]
type = "spring"
dofs = ["1:x"]
k = {K1}

[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"

[[element]]
type = "mass"
dofs = ["1:x"]
m = {M1}

[[element]]
type = "mass"
dofs = ["2:x"]
m = {M2}

[damping]
modal = ["z1", "z2"]

[damping.parameters.z1]
value = {Z[0]}
bounds = [0.0, 0.5]

[damping.parameters.z2]
value = {Z[1]}
bounds = [0.0, 0.5]
""")
    dm = load_damped_model(p)
    w2, V = la.eigh(np.array([[K1 + K2, -K2], [-K2, K2]]), np.diag([M1, M2]))
    om = 2 * np.pi * np.linspace(1.0, 12.0, 56)  # the top mode at 7.1 Hz (8.3 Hz at the start)
    X = np.array([V @ ((V.T @ [0.0, 1.0]) / (w2 - w ** 2 + 2j * np.asarray(Z) * np.sqrt(w2) * w)) for w in om])
    res = femupdate.updating.frf_update(dm.with_values({"k2": 1000.0, "z1": 0.05, "z2": 0.01}),
                                        TestData(frf=FRFData(om, {"2:x": 1.0}, ("1:x", "2:x"), X)))
    assert not any("the FRF lines reach" in n for n in res.notes), res.notes
    for n, v in (("k2", K2), ("z1", Z[0]), ("z2", Z[1])):
        assert res.parameters[n] == pytest.approx(v, rel=1e-6), n
