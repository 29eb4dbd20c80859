"""What the ordinate of a universal-file FRF (dataset 58) holds: decibels, logarithms, phases,
magnitudes and parts are refused by the record and field, linear units are converted (issue 34,
item 3).  Every file is written by pyuff's own writer."""

from __future__ import annotations

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from femupdate import InputError  # noqa: E402
from femupdate.examples import two_dof  # noqa: E402
from femupdate.io.uff import read_uff  # noqa: E402
from femupdate.updating import frf_update  # noqa: E402

G_N = 9.80665
OMEGA = np.linspace(0.4, 2.8, 25)


def receptance(k1=8.0, k2=6.0, omega=OMEGA, eta=0.0):
    """Closed form: columns H_11, H_21 of the two-dof chain (masses 2, 4), force at 1:x."""
    K = np.array([[k1 + k2, -k2], [-k2, k2]]) * (1 + 1j * eta)
    M = np.diag([2.0, 4.0])
    H = np.array([np.linalg.solve(K - w ** 2 * M, [1.0, 0.0]) for w in omega])
    return H if eta else H.real


def record(node, values, *, spec=8, axis="NONE", units="NONE", denominator="NONE", abscissa="Hz"):
    """A dataset 58 FRF record at node ``node`` (x), excitation 1:x, as pyuff writes it."""
    values = np.asarray(values)
    ds = pyuff.prepare_58(
        binary=0, id1="test", id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=4, ver_num=0,
        load_case_id=0, rsp_ent_name="NONE", rsp_node=node, rsp_dir=1, ref_ent_name="NONE", ref_node=1, ref_dir=1,
        ord_data_type=6 if np.iscomplexobj(values) else 4, num_pts=values.size, abscissa_spacing=0,
        abscissa_min=0.0, abscissa_inc=0.0, z_axis_value=0.0, abscissa_spec_data_type=18, abscissa_len_unit_exp=0,
        abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0, abscissa_axis_units_lab=abscissa,
        ordinate_spec_data_type=spec, ordinate_len_unit_exp=0, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
        ordinate_axis_units_lab=units, orddenom_spec_data_type=13, orddenom_len_unit_exp=0,
        orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0, orddenom_axis_units_lab=denominator,
        z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
        z_axis_axis_units_lab="NONE", data=values, x=OMEGA / (2 * np.pi))
    ds["ordinate_axis_lab"] = axis  # prepare_58 has no argument for it; the writer reads the key
    return ds


def write(path, *sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="overwrite")
    return path


def both(H, transform=lambda h: h, **kw):
    return [record(n, transform(H[:, n - 1]), **kw) for n in (1, 2)]


@pytest.mark.parametrize("transform, kw, fragment", [
    (lambda h: 20 * np.log10(np.abs(h)), {"units": "dB"}, "ordinate units label 'dB' (record 9, field 6)"),
    (lambda h: 20 * np.log10(np.abs(h)), {"units": "dB re 1 m/N"}, "decibels"),
    (lambda h: np.log10(np.abs(h)), {"axis": "Log Magnitude"}, "ordinate axis label 'Log Magnitude' (record 9, field 5)"),
    (lambda h: np.degrees(np.angle(h)), {"units": "deg"}, "a phase"),
    (lambda h: np.angle(h), {"units": "rad"}, "angles"),
    (lambda h: np.angle(h), {"axis": "Phase"}, "a phase"),
    (np.abs, {"axis": "Magnitude"}, "a magnitude: the phase is lost"),
    (np.abs, {"axis": "Amplitude", "units": "m/N"}, "a magnitude"),
    (lambda h: h.imag, {"axis": "Imaginary"}, "an imaginary part alone"),
    (lambda h: h.real, {"axis": "Real"}, "a real part alone"),
    (lambda h: np.abs(h) * np.exp(1j * np.angle(h)), {"axis": "Magnitude/Phase"}, "magnitude and phase pairs"),
], ids=["dB", "dB re", "log", "deg", "rad", "phase", "magnitude", "amplitude", "imaginary", "real part", "mag/phase"])
def test_ordinates_that_are_not_an_frf_are_refused_by_record_and_field(tmp_path, transform, kw, fragment):
    H = receptance(eta=0.02)
    path = write(tmp_path / "h.uff", *both(H, transform, **kw))
    with pytest.raises(InputError) as info:
        read_uff(path)
    msg = str(info.value)
    assert f"{path}: dataset 58 record 1" in msg and fragment in msg, msg


def test_the_issue_example_in_decibels_no_longer_converges_to_a_wrong_answer(tmp_path):
    """Before: read as linear receptance, k1 = 3.69, k2 = 6.37 (truth 8, 6), 'converged'."""
    H = receptance()
    linear = read_uff(write(tmp_path / "lin.uff", *both(H)))
    res = frf_update(two_dof(), linear.frf)
    np.testing.assert_allclose([res.parameters["k1"], res.parameters["k2"]], [8.0, 6.0], rtol=1e-4)
    with pytest.raises(InputError, match="decibels"):
        read_uff(write(tmp_path / "db.uff", *both(H, lambda h: 20 * np.log10(np.abs(h)), units="dB")))


@pytest.mark.parametrize("spec, kw, scale, kind", [
    (12, {"units": "g/N"}, lambda w: -(w ** 2) / G_N, "accelerance in g/N"),
    (12, {"units": "(m/s^2)/N"}, lambda w: -(w ** 2), "accelerance in SI"),
    (0, {"units": "m/s²/N"}, lambda w: -(w ** 2), "unknown type, unit says accelerance"),
    (1, {"units": "mm/N"}, lambda w: 1e3 + 0 * w, "general type in mm/N"),
    (11, {"units": "mm/s", "denominator": "N"}, lambda w: 1e3j * w, "mobility, force in the denominator's label"),
    (8, {"units": "m/kN"}, lambda w: 1e3 + 0 * w, "per kilonewton"),
    (12, {"units": "g"}, lambda w: -(w ** 2) / G_N, "numerator alone in g, force in the file's unit (N)"),
    (12, {"units": "mm/s^2"}, lambda w: -(w ** 2) * 1e3, "numerator alone in mm/s^2"),
], ids=lambda v: v if isinstance(v, str) else None)
def test_linear_units_labels_are_converted_to_si(tmp_path, spec, kw, scale, kind):
    H = receptance(eta=0.02)
    file_values = H * scale(OMEGA)[:, None]  # what an instrument writes in the labelled units
    data = read_uff(write(tmp_path / "h.uff", *[record(n, file_values[:, n - 1], spec=spec, **kw) for n in (1, 2)]))
    # the abscissa is written in E13.5 (ω to ~5e-6), so a division by ω or ω² agrees to ~1e-5
    np.testing.assert_allclose(data.frf.response, H, rtol=3e-5, atol=0)
    res = frf_update(two_dof(), data.frf, damping={"eta": 0.02})
    np.testing.assert_allclose([res.parameters["k1"], res.parameters["k2"]], [8.0, 6.0], rtol=1e-3)


def test_a_units_label_wins_over_dataset_164_and_says_so(tmp_path):
    units = pyuff.prepare_164(units_code=5, units_description="mm mN", temp_mode=1, length=1000.0, force=1000.0,
                              temp=1.0, temp_offset=273.15)
    H = receptance()
    data = read_uff(write(tmp_path / "h.uff", units, *both(H, lambda h: h * 1e3, units="mm/N")))
    np.testing.assert_allclose(data.frf.response, H, rtol=1e-10)
    assert any("ordinate in mm/N" in n and "record 9, field 6" in n for n in data.notes), data.notes


def test_a_numerator_in_g_over_the_force_unit_of_dataset_164(tmp_path):
    """Accelerance in g per millinewton: the label gives the numerator, dataset 164 the force."""
    units = pyuff.prepare_164(units_code=9, units_description="g per mN", temp_mode=1, length=1.0, force=1000.0,
                              temp=1.0, temp_offset=273.15)
    H = receptance(eta=0.02)
    file_values = H * (-(OMEGA ** 2) / G_N / 1000.0)[:, None]  # x in g, F in mN
    data = read_uff(write(tmp_path / "h.uff", units, *[record(n, file_values[:, n - 1], spec=12, units="g")
                                                          for n in (1, 2)]))
    np.testing.assert_allclose(data.frf.response, H, rtol=3e-5)
    assert any("ordinate in g per the file's force unit" in n for n in data.notes), data.notes


@pytest.mark.parametrize("spec, units", [(8, "m/s^2/N"), (12, "m/N"), (11, "g/N")])
def test_a_units_label_that_contradicts_the_data_type_is_refused(tmp_path, spec, units):
    path = write(tmp_path / "h.uff", *both(receptance(), units=units, spec=spec))
    with pytest.raises(InputError, match=r"dataset 58 record 1: ordinate units label .* contradicts itself"):
        read_uff(path)


@pytest.mark.parametrize("axis, units", [("Real/Imag", "NONE"), ("Re-Im", "m/N"), ("Receptance", "m/N"),
                                         ("NONE", "NONE")])
def test_complex_records_with_plain_labels_read_as_before(tmp_path, axis, units):
    H = receptance(eta=0.05)
    data = read_uff(write(tmp_path / "h.uff", *both(H, axis=axis, units=units)))
    np.testing.assert_allclose(data.frf.response, H, rtol=1e-10)
    assert not [n for n in data.notes if "record 9" in n]


def test_an_unknown_units_label_is_named_in_a_note(tmp_path):
    H = receptance(eta=0.05)
    data = read_uff(write(tmp_path / "h.uff", *both(H, units="furlong/N")))
    np.testing.assert_allclose(data.frf.response, H, rtol=1e-10)
    assert any("'furlong/N' (record 9, field 6) not recognised" in n for n in data.notes), data.notes
