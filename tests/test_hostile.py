"""The standing campaign of issue 34: the hostile inputs found by the review, as one table —
input, command, expected exit code, culprit named in the message — run through the command line
in process, so that no later change brings one back.

Every case also checks what holds for all of them: no traceback, no RuntimeWarning (extreme values
are refused or handled, never warned about), and, for a refusal, every file that existed before
the run is unchanged (same bytes, same inode: nothing lost, nothing overwritten).

Earlier campaigns live in tests/test_bad_input.py (the option and file matrix of issue 16),
tests/test_refusals.py and tests/test_fuzz.py; the cases that need special files, other users or
signals are in tests/test_outputs.py and tests/test_signals.py.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from femupdate.cli import main
from femupdate.examples import example_files

pyuff = pytest.importorskip("pyuff")


# ---------------------------------------------------------------------------------- inputs
def two_dof_receptance(omega, k1=8.0, k2=6.0, eta=0.0):
    K = np.array([[k1 + k2, -k2], [-k2, k2]]) * (1 + 1j * eta)
    return np.array([np.linalg.solve(K - w ** 2 * np.diag([2.0, 4.0]), [1.0, 0.0]) for w in omega])


def frf_record(node, f_hz, values, spec=8, units="NONE"):
    values = np.asarray(values)
    return pyuff.prepare_58(
        binary=0, func_type=4, rsp_node=node, rsp_dir=1, ref_node=1, ref_dir=1, ord_data_type=6 if np.iscomplexobj(
            values) else 4, abscissa_spacing=0, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=spec, ordinate_axis_units_lab=units, orddenom_spec_data_type=13, data=values,
        x=np.asarray(f_hz, float))


def mode_record(freq, r):
    r = np.asarray(r, float)
    return pyuff.prepare_55(model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
                            n_data_per_node=3, node_nums=np.array([1, 2]), load_case=1, mode_n=1, freq=float(freq),
                            modal_m=0.0, modal_damp_vis=0.0, modal_damp_his=0.0, r1=r[:, 0].copy(),
                            r2=r[:, 1].copy(), r3=r[:, 2].copy())


def units_record(length, force=1.0):
    return pyuff.prepare_164(units_code=9, units_description="user", temp_mode=1, length=length, force=force,
                             temp=1.0, temp_offset=273.15)


def uff(name, *sets):
    def make(d: Path):
        pyuff.UFF(str(d / name)).write_sets(list(sets), mode="overwrite")
    return make


def frf_uff(name, transform=lambda h: h, spec=8, units="NONE", f_scale=1.0):
    omega = np.linspace(0.4, 2.8, 25)
    H = two_dof_receptance(omega, eta=0.02)
    return uff(name, *[frf_record(n, omega / (2 * np.pi) * f_scale, transform(H[:, n - 1]), spec, units) for n in (1, 2)])


def text(name, content: str | bytes):
    def make(d: Path):
        (d / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    return make


def matrix_model(dofs_entry='dofs = "dofs.txt"'):
    def make(d: Path):
        np.save(d / "K0.npy", np.diag([2.0, 1.0]))
        np.save(d / "M0.npy", np.eye(2))
        np.save(d / "dK.npy", np.diag([1.0, 0.0]))
        (d / "m.toml").write_text(f'[matrices]\n{dofs_entry}\nK0 = "K0.npy"\nM0 = "M0.npy"\n'
                                  '[parameters.k1]\nvalue = 1.0\nK = "dK.npy"\n')
    return make


def frf_json(name, scale):
    def make(d: Path):
        raw = json.loads(example_files()["two_dof_frf.json"])
        raw["frf"]["response"] = {k: [v * scale for v in vals] if not isinstance(vals[0], list)
                                  else [[x * scale for x in pair] for pair in vals]
                                  for k, vals in raw["frf"]["response"].items()}
        (d / name).write_text(json.dumps(raw))
    return make


def link(name, target, hard=False):
    def make(d: Path):
        (os.link if hard else os.symlink)(d / target, d / name)
    return make


# ---------------------------------------------------------------------------------- the table
@dataclass
class Case:
    """One hostile input: files made in the run's folder, the command (``{d}`` is the folder), the
    exit code and the fragments the message must hold (the culprit as the user wrote it)."""

    id: str
    args: list[str]
    exit: int
    culprit: tuple[str, ...] = ()
    make: list[Callable[[Path], None]] = field(default_factory=list)
    #: for a run that succeeds: the answer it must give ({"parameters": {name: value}} or {"n_modes": n}),
    #: read from its --json result (relative tolerance 1e-3)
    answer: dict = field(default_factory=dict)


MODEL, DATA, FRF = "{d}/two_dof.toml", "{d}/two_dof_frequencies.json", "{d}/two_dof_frf.json"
D_B = lambda h: 20 * np.log10(np.abs(h))  # noqa: E731

CASES = [
    # 1. an output that is an input: refused before any work, naming both
    Case("json onto the test data", ["update", MODEL, DATA, "--json", DATA], 2,
         ("--json", "two_dof_frequencies.json: is the input DATA", "writing there would destroy it")),
    Case("uff onto the measured universal file", ["update", MODEL, "{d}/test.uff", "--uff", "{d}/test.uff"], 2,
         ("--uff {d}/test.uff: is the input DATA",), [frf_uff("test.uff")]),
    Case("write-model onto the model", ["update", MODEL, DATA, "--write-model", MODEL], 2,
         ("--write-model {d}/two_dof.toml: is the input MODEL",)),
    Case("json onto a hard link of the model", ["update", MODEL, DATA, "--json", "{d}/model.json"], 2,
         ("--json {d}/model.json: is the input MODEL ({d}/two_dof.toml)",), [link("model.json", "two_dof.toml", True)]),
    Case("json onto a symbolic link to the data", ["update", MODEL, DATA, "--json", "{d}/link.json"], 2,
         ("--json {d}/link.json: is the input DATA",), [link("link.json", "two_dof_frequencies.json")]),
    Case("json onto the dofs file of a matrix model", ["modes", "{d}/m.toml", "--json", "{d}/dofs.txt"], 2,
         ("--json {d}/dofs.txt: is the dofs file of {d}/m.toml",), [matrix_model(), text("dofs.txt", "1:x\n2:x\n")]),
    Case("json onto a matrix file of the model", ["modes", "{d}/m.toml", "--json", "{d}/K0.npy"], 2,
         ("--json {d}/K0.npy: is the matrix file of {d}/m.toml: [matrices] K0",),
         [matrix_model(), text("dofs.txt", "1:x\n2:x\n")]),
    Case("convert-data onto its source", ["convert-data", DATA, DATA], 2, ("OUT", "is the input SOURCE")),
    Case("one file for two outputs", ["update", MODEL, DATA, "--json", "{d}/out.x", "--uff", "{d}/out.x"], 2,
         ("the same file as",)),
    # 6. numbers and paths whose messages said what was not wrong
    Case("1e308 in a JSON file", ["update", MODEL, "{d}/big.json"], 2,
         ("{d}/big.json", "modes[1].eigenvalue: 1e+308 is too large"), [text("big.json", '{"modes": [{"eigenvalue": 1e308}]}')]),
    Case("1e400 in a JSON file", ["update", MODEL, "{d}/big.json"], 2,
         ("modes[1].eigenvalue: 1e400 is too large",), [text("big.json", '{"modes": [{"eigenvalue": 1e400}]}')]),
    Case("1e400 in a TOML file", ["modes", "{d}/big.toml"], 2, ("{d}/big.toml: parameters.k1.value: 1e400 is too large",),
         [text("big.toml", example_files()["two_dof.toml"].replace("value = 7.0", "value = 1e400", 1))]),
    Case("a byte-order mark in a dofs file", ["modes", "{d}/m.toml"], 0, (),
         [matrix_model(), text("dofs.txt", b"\xef\xbb\xbf1:x\n2:x\n")], {"dofs": ["1:x", "2:x"]}),
    Case("a dofs path that is a folder", ["modes", "{d}/m.toml"], 2, ("dofs file {d}/dofs", "is a folder"),
         [matrix_model('dofs = "dofs"'), lambda d: (d / "dofs").mkdir()]),
    # 3. universal-file ordinates that are not an FRF: were read as linear receptance, exit 0
    Case("UFF 58 in decibels", ["frf-update", MODEL, "{d}/db.uff"], 2,
         ("{d}/db.uff: dataset 58 record 1: ordinate units label 'dB' (record 9, field 6)",),
         [frf_uff("db.uff", D_B, units="dB")]),
    Case("UFF 58 phase in degrees", ["update", MODEL, "{d}/ph.uff"], 2, ("dataset 58 record 1", "'deg'", "a phase"),
         [frf_uff("ph.uff", lambda h: np.degrees(np.angle(h)), units="deg")]),
    Case("UFF 58 accelerance in g/N", ["frf-update", MODEL, "{d}/g.uff", "--damping", "eta=0.02"], 0, (),
         [frf_uff("g.uff", lambda h: h * -(np.linspace(0.4, 2.8, 25) ** 2) / 9.80665, spec=12, units="g/N")],
         {"parameters": {"k1": 8.0, "k2": 6.0}}),  # read as m/s²/N, it 'converged' elsewhere
    # 6. extreme values that leaked RuntimeWarnings (or a traceback)
    Case("UFF 55 shape overflowing the length unit", ["correlate", MODEL, "{d}/m.uff"], 2,
         ("{d}/m.uff: dataset 55 record 1", "too large to convert to SI"),
         [uff("m.uff", units_record(1e-300), mode_record(0.14, [[1e150, 0, 0], [2e150, 0, 0]]))]),
    Case("UFF 55 frequency 1e300 Hz", ["correlate", MODEL, "{d}/f.uff"], 2,
         ("{d}/f.uff: dataset 55 record 1", "frequency 1e+300 Hz is above 1e+150"),
         [uff("f.uff", mode_record(1e300, [[1, 0, 0], [2, 0, 0]]))]),
    Case("UFF 58 accelerance at 1e-300 Hz", ["frf-update", MODEL, "{d}/a.uff"], 2,
         ("{d}/a.uff: dataset 58 record 1", "accelerance too large"), [frf_uff("a.uff", spec=12, f_scale=1e-300)]),
    Case("FRF data 1e-140 of the model's", ["frf-update", MODEL, "{d}/tiny.json"], 2,
         ("weighted residuals at the starting values reach", "check the units"), [frf_json("tiny.json", 1e-140)]),
    Case("a standard deviation 1e-150 of data of 1e140", ["frf-update", MODEL, "{d}/huge.json", "--std", "1e-150"], 2,
         ("weighted residuals at the starting values",), [frf_json("huge.json", 1e140)]),
    Case("FRF data 1e149 of the model's", ["frf-update", MODEL, "{d}/huge.json"], 0, (), [frf_json("huge.json", 1e149)]),
]


def _snapshot(d: Path) -> dict[str, tuple[bytes, int]]:
    return {str(p): (p.read_bytes(), p.stat().st_ino) for p in d.rglob("*") if p.is_file() and not p.is_symlink()}


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_hostile_case(tmp_path, capsys, case):
    for name in ("two_dof.toml", "two_dof_frequencies.json", "two_dof_frf.json"):
        (tmp_path / name).write_text(example_files()[name])
    for make in case.make:
        make(tmp_path)
    before = _snapshot(tmp_path)
    args = [a.format(d=tmp_path) for a in case.args]
    if case.answer:
        args += ["--json", str(tmp_path / "answer.json")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(SystemExit) as info:
            main(args)
    out, err = capsys.readouterr()
    assert info.value.code == case.exit, err or out
    assert "Traceback" not in out + err
    for fragment in case.culprit:
        assert fragment.format(d=tmp_path) in err, err
    leaked = [f"{w.category.__name__}: {w.message} ({w.filename}:{w.lineno})" for w in caught
              if issubclass(w.category, RuntimeWarning)]
    assert not leaked, leaked
    if case.exit:
        assert _snapshot(tmp_path) == before  # nothing lost, nothing overwritten
    if case.answer:
        got = json.loads((tmp_path / "answer.json").read_text())
        for key, want in case.answer.items():
            if key == "parameters":
                for name, value in want.items():
                    assert got["parameters"][name] == pytest.approx(value, rel=1e-3), got["parameters"]
            else:
                assert got[key] == want, got[key]
