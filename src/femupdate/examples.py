"""Small models of the reference paper, built with the public Structure API.

The paper gives the 2-dof system's values (m1 = 2, m2 = 4, k1 = 8, k2 = 6, eq. 11 onwards) but
no values for the 3-dof systems of Figures 1 and 2; the defaults chosen here are documented in
each function and in docs/paper.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .model import Model
from .structure import Structure


def two_dof(k1: float = 8.0, k2: float = 6.0, m1: float = 2.0, m2: float = 4.0,
            bounds: tuple[float, float] = (0.0, 100.0)) -> Model:
    """Figure 3: ground -k1- m1 -k2- m2.  K = [[k1+k2, -k2], [-k2, k2]], M = diag(m1, m2).

    Parameters
    ----------
    k1, k2 : float, default 8.0 and 6.0
        Spring stiffnesses (N/m in SI; the paper gives bare numbers): the model's parameters
        ``k1`` and ``k2``.
    m1, m2 : float, default 2.0 and 4.0
        Masses at dofs ``1:x`` and ``2:x`` (kg), fixed.
    bounds : (float, float), default (0.0, 100.0)
        Bounds of both parameters.

    Returns
    -------
    Model
        Dofs ``1:x``, ``2:x``.

    Raises
    ------
    InputError
        A stiffness outside ``bounds`` or not finite, or as :meth:`femupdate.Structure.build`.
    """
    s = Structure("two-dof chain (paper Figure 3)")
    s.parameter("k1", k1, bounds)
    s.parameter("k2", k2, bounds)
    s.spring(["1:x"], k="k1")
    s.spring(["1:x", "2:x"], k="k2")
    s.mass(["1:x"], m=m1)
    s.mass(["2:x"], m=m2)
    return s.build()


# Figures 1 and 2 carry no numbers; these values make a well-separated, realistic example.
FIGURE1_STIFFNESS = (1000.0, 2000.0, 1500.0)  # N/m
FIGURE1_MASS = (1.0, 1.5, 2.0)  # kg
FIGURE2_K4 = 500.0  # N/m


def three_dof(k: Sequence[float] = FIGURE1_STIFFNESS, m: Sequence[float] = FIGURE1_MASS,
              k4: float | None = None, bounds: tuple[float, float] = (0.0, 1.0e5)) -> Model:
    """Figures 1 and 2: ground -k1- m1 -k2- m2 -k3- m3, plus k4 between dofs 1 and 3 if given.

    K (Figure 1) = [[k1+k2, -k2, 0], [-k2, k2+k3, -k3], [0, -k3, k3]]; Figure 2 adds k4 to
    K11, K33 and -k4 to K13, K31.

    Parameters
    ----------
    k : sequence of 3 float, default ``FIGURE1_STIFFNESS`` = (1000, 2000, 1500)
        k1, k2, k3, N/m: the parameters ``k1``, ``k2``, ``k3``.
    m : sequence of 3 float, default ``FIGURE1_MASS`` = (1.0, 1.5, 2.0)
        Masses at dofs ``1:x``, ``2:x``, ``3:x``, kg.
    k4 : float, optional
        Stiffness of the spring between dofs 1 and 3 (N/m), the parameter ``k4`` of Figure 2; no
        such spring when omitted (Figure 1).
    bounds : (float, float), default (0.0, 1e5)
        Bounds of every parameter.

    Returns
    -------
    Model
        Dofs ``1:x``, ``2:x``, ``3:x``.

    Raises
    ------
    InputError
        A stiffness outside ``bounds`` or not finite, ``k`` with fewer than 3 values, or as
        :meth:`femupdate.Structure.build`.
    """
    s = Structure("three-dof chain (paper Figure 2)" if k4 is not None else "three-dof chain (paper Figure 1)")
    for i, v in enumerate(k, start=1):
        s.parameter(f"k{i}", v, bounds)
    s.spring(["1:x"], k="k1")
    s.spring(["1:x", "2:x"], k="k2")
    s.spring(["2:x", "3:x"], k="k3")
    if k4 is not None:
        s.parameter("k4", k4, bounds)
        s.spring(["1:x", "3:x"], k="k4")
    for i, v in enumerate(m, start=1):
        s.mass([f"{i}:x"], m=v)
    return s.build()


def chain(stiffness: Sequence[float], mass: Sequence[float], name: str = "spring-mass chain",
          bounds: tuple[float, float] = (0.0, float("inf"))) -> Model:
    """Grounded chain of N masses and N springs (k_i between dof i-1 and i, dof 0 = ground).

    Parameters
    ----------
    stiffness : sequence of float, length N
        Spring stiffnesses k_1 .. k_N, N/m: the parameters ``k1`` .. ``kN``.
    mass : sequence of float, length N
        Masses at dofs ``1:x`` .. ``N:x``, kg (fixed).
    name : str, default "spring-mass chain"
        Model name.
    bounds : (float, float), default (0, inf)
        Bounds of every parameter.

    Returns
    -------
    Model
        Dofs ``1:x`` .. ``N:x``.

    Raises
    ------
    ValueError
        ``stiffness`` and ``mass`` differ in length (a plain ValueError, not an InputError).
    InputError
        A stiffness outside ``bounds`` or not finite, or as :meth:`femupdate.Structure.build`.
    """
    if len(stiffness) != len(mass):
        raise ValueError("chain: one stiffness per mass")
    s = Structure(name)
    for i, (k, m) in enumerate(zip(stiffness, mass), start=1):
        s.parameter(f"k{i}", k, bounds)
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=m)
    return s.build()


def portal_frame(E_columns: float = 2.1e11, E_beam: float = 2.1e11, n_per_member: int = 4) -> Model:
    """A fixed-base planar portal frame (beam2d): two 3 m columns and a 4 m beam.

    Parameters ``E_col`` (both columns, grouped) and ``E_beam``; steel box section
    A = 4e-3 m^2, I = 1.2e-5 m^4, rho = 7850 kg/m^3; consistent mass.

    Parameters
    ----------
    E_columns : float, default 2.1e11
        Young's modulus of the columns, Pa (parameter ``E_col``, bounds 1e10 .. 5e11).
    E_beam : float, default 2.1e11
        Young's modulus of the beam, Pa (parameter ``E_beam``, bounds 1e10 .. 5e11).
    n_per_member : int, default 4
        Elements per member; nodes are numbered 1 .. 3 n + 1 from the left foot, over the beam, to
        the right foot, and both feet are fixed.

    Returns
    -------
    Model
        Dofs ``x, y, rz`` at the 3 n − 1 free nodes.

    Raises
    ------
    InputError
        A modulus outside its bounds, or as :meth:`femupdate.Structure.build`.
    """
    import numpy as np

    s = Structure("portal frame")
    s.parameter("E_col", E_columns, (1e10, 5e11))
    s.parameter("E_beam", E_beam, (1e10, 5e11))
    n = n_per_member
    h, w = 3.0, 4.0
    left = [(0.0, h * i / n) for i in range(n + 1)]
    top = [(w * i / n, h) for i in range(1, n + 1)]
    right = [(w, h - h * i / n) for i in range(1, n + 1)]
    pts = left + top + right
    s.add_nodes(range(1, len(pts) + 1), pts)
    ids = np.arange(1, len(pts) + 1)
    col_l = np.c_[ids[:n], ids[1 : n + 1]]
    beam = np.c_[ids[n : 2 * n], ids[n + 1 : 2 * n + 1]]
    col_r = np.c_[ids[2 * n : 3 * n], ids[2 * n + 1 : 3 * n + 1]]
    sec: dict[str, Any] = dict(A=4e-3, I=1.2e-5, rho=7850.0)  # keyword arguments of beam2d
    s.beam2d(np.r_[col_l, col_r], E="E_col", where="columns", **sec)
    s.beam2d(beam, E="E_beam", where="beam", **sec)
    s.support_node([1, len(pts)])
    return s.build()


# true values of the built-in demonstration (package data figure2.toml / figure2_test.json)
FIGURE2_TRUE = {"k1": 1000.0, "k2": 2000.0, "k3": 1500.0, "k4": 500.0}
FIGURE2_START = {"k1": 700.0, "k2": 2600.0, "k3": 1200.0, "k4": 800.0}


def figure2_test_data(noise: float = 0.01, seed: int = 1993) -> dict:
    """Simulated test of the Figure 2 system at the true values ``FIGURE2_TRUE``.

    All three modes at every dof; shapes scaled to 1 at their largest entry and perturbed by
    Gaussian noise of standard deviation ``noise`` (relative to that entry); frequencies
    perturbed by ``noise / 10`` (relative).  Returns the test-data JSON object (docs/file-formats.md).

    Parameters
    ----------
    noise : float, default 0.01
        Relative standard deviation of the shape noise (one tenth of it on the frequencies).
    seed : int, default 1993
        Seed of :func:`numpy.random.default_rng`.

    Returns
    -------
    dict
        ``{"modes": [{"frequency_hz": f, "shape": {dof: value}}, ...]}``: three modes, frequencies in
        Hz, shapes at ``1:x``, ``2:x``, ``3:x``, values rounded to 6 decimals.
    """
    import numpy as np

    from .modal import model_modes

    rng = np.random.default_rng(seed)
    truth = three_dof(k=[FIGURE2_TRUE[f"k{i}"] for i in (1, 2, 3)], k4=FIGURE2_TRUE["k4"])
    modes = model_modes(truth, normalisation="max")
    out = []
    for r in range(modes.n_modes):
        f = modes.frequencies_hz[r] * (1 + noise / 10 * rng.standard_normal())
        shape = modes.shapes[:, r] + noise * rng.standard_normal(truth.n_dofs)
        out.append({"frequency_hz": round(float(f), 6),
                    "shape": {d: round(float(v), 6) for d, v in zip(truth.dofs, shape)}})
    return {"modes": out}


def demo():
    """The identification ``femupdate demo`` makes: the Figure 2 system (package data
    ``figure2.toml``, at the wrong starting values ``FIGURE2_START``) identified directly from its
    built-in test (``figure2_test.json``: three modes at every dof, simulated at ``FIGURE2_TRUE``
    with 1 % noise on the shapes; :func:`figure2_test_data`).

    Returns
    -------
    DirectResult
        Of kind ``demo``: ``to_json()`` is what ``femupdate demo --json`` writes (the keys of
        ``direct`` with ``true``, without ``start`` and ``units``); its context holds the model and
        the test data (``result.run_context.model``, ``.data``).
    """
    from importlib import resources

    from .direct import direct_update
    from .io.model_file import load_model
    from .io.testdata_json import load_testdata

    data_dir = resources.files("femupdate") / "data"
    with resources.as_file(data_dir / "figure2.toml") as mpath, resources.as_file(data_dir / "figure2_test.json") as dpath:
        model = load_model(mpath)
        data = load_testdata(dpath, model)
    return direct_update(model, data).with_context(kind="demo")


def figure2_model_toml() -> str:
    """TOML text of the Figure 2 model at the (wrong) starting values ``FIGURE2_START``."""
    lines = ['[model]', 'name = "three-dof chain with k4 (paper Figure 2)"', ""]
    for name, v in FIGURE2_START.items():
        lines += [f"[parameters.{name}]", f"value = {v}", "bounds = [0.0, 1.0e5]", ""]
    springs = [(["1:x"], "k1"), (["1:x", "2:x"], "k2"), (["2:x", "3:x"], "k3"), (["1:x", "3:x"], "k4")]
    for dofs, k in springs:
        lines += ["[[element]]", 'type = "spring"', f"dofs = {dofs}".replace("'", '"'), f'k = "{k}"', ""]
    for i, m in enumerate(FIGURE1_MASS, start=1):
        lines += ["[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {m}", ""]
    return "\n".join(lines)


# ------------------------------------------------------------------------------- example files
TWO_DOF_START = {"k1": 7.0, "k2": 6.5}  # the example's (wrong) starting values; the truth is (8, 6)
TRUSS_DAMAGED = "E.102-103"  # the member that loses stiffness in the damage example
TRUSS_LOSS = 0.4


def two_dof_model_toml(values=TWO_DOF_START) -> str:
    """TOML of the Figure 3 system at ``values``, bounds of the paper's surfaces (k1 3..13, k2 1..11).

    Parameters
    ----------
    values : mapping, default ``TWO_DOF_START`` = {"k1": 7.0, "k2": 6.5}
        Values of ``k1`` and ``k2`` (N/m); masses are 2 and 4 kg as in :func:`two_dof`.

    Returns
    -------
    str
        The model file's text (docs/file-formats.md).

    Raises
    ------
    KeyError
        ``values`` lacks ``k1`` or ``k2``.
    """
    lines = ['[model]', 'name = "two-dof chain (paper Figure 3)"', ""]
    for name, b in (("k1", "[3.0, 13.0]"), ("k2", "[1.0, 11.0]")):
        lines += [f"[parameters.{name}]", f"value = {values[name]}", f"bounds = {b}", ""]
    for dofs, k in ((["1:x"], "k1"), (["1:x", "2:x"], "k2")):
        lines += ["[[element]]", 'type = "spring"', f"dofs = {dofs}".replace("'", '"'), f'k = "{k}"', ""]
    for i, m in ((1, 2.0), (2, 4.0)):
        lines += ["[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {m}", ""]
    return "\n".join(lines)


def truss_model_toml() -> str:
    """TOML of a 3-bay plane truss (aluminium rods, one shared modulus E, 2 kg at six joints):
    the baseline of the damage example."""
    nodes = [(1, 0, 0), (2, 1, 0), (3, 2, 0), (4, 3, 0), (101, 0, 1), (102, 1, 1), (103, 2, 1), (104, 3, 1)]
    pairs = [(1, 2), (2, 3), (3, 4), (101, 102), (102, 103), (103, 104), (2, 102), (3, 103), (4, 104), (1, 102),
             (2, 103), (3, 104)]
    lines = ['[model]', 'name = "3-bay plane truss"', "", "[parameters.E]", "value = 7.0e10", "bounds = [1.0e10, 1.0e11]", ""]
    for i, x, y in nodes:
        lines += ["[[node]]", f"id = {i}", f"xyz = [{x:.1f}, {y:.1f}]", ""]
    for a, b in pairs:
        lines += ["[[element]]", 'type = "rod"', f"nodes = [{a}, {b}]", 'E = "E"', "A = 4e-4", "rho = 2700.0", "dim = 2",
                  'mass = "lumped"', ""]
    for n in (2, 3, 4, 102, 103, 104):
        lines += ["[[element]]", 'type = "mass"', f'dofs = ["{n}:x", "{n}:y"]', "m = 2.0", ""]
    lines += ["[[support]]", 'dofs = ["1:x", "1:y", "101:x", "101:y"]', ""]
    return "\n".join(lines)


#: the damping of ``truss_damped.toml``: Rayleigh α (1/s), β (s) and two dampers' coefficients (N s/m)
TRUSS_DAMPING = {"alpha": 0.5, "beta": 2.0e-5, "c1": 400.0, "c2": 250.0}


def truss_damped_model_toml() -> str:
    """TOML of the 3-bay truss (:func:`truss_model_toml`) with a ``[damping]`` table: Rayleigh
    damping (α a number, β a damping parameter) and two viscous dampers, ``c1`` across the right
    bay's diagonal (4:x to 104:y) and ``c2`` from joint 103 to the ground (vertical)."""
    d = TRUSS_DAMPING
    return truss_model_toml().replace('name = "3-bay plane truss"', 'name = "3-bay plane truss with dampers"') + f"""
[damping]
alpha = {d['alpha']}
beta = "b"

[damping.parameters.b]
value = {d['beta']:.1e}
bounds = [0.0, 1.0e-3]

[damping.parameters.c1]
value = {d['c1']}
bounds = [0.0, 1.0e4]

[damping.parameters.c2]
value = {d['c2']}
bounds = [0.0, 1.0e4]

[[damping.damper]]
dofs = ["4:x", "104:y"]
c = "c1"

[[damping.damper]]
dofs = ["103:y"]
c = "c2"
"""


#: the starting values of the damped truss's update in docs/damping.md (``--set``), away from the truth
TRUSS_DAMPED_START = {"E": 6.0e10, "b": 5.0e-5, "c1": 100.0, "c2": 600.0}
#: the FRFs of ``truss_damped_frf.json``: a unit force at 4:y, responses at these dofs, 20-300 Hz every 2 Hz
TRUSS_DAMPED_FRF: dict[str, Any] = {"force": "4:y", "dofs": ("3:y", "4:y", "104:y"), "hz": (20.0, 300.0, 141)}


def truss_damped_test_files() -> dict[str, str]:
    """Noise-free test data of the damped truss (``truss_damped.toml`` at its own values), as
    {name: JSON text}: ``truss_damped_modes.json`` (its 4 lowest complex modes at every joint
    dof: natural frequency :math:`|\\lambda|/2\\pi`, damping ratio, complex shape scaled to 1 at its largest entry)
    and ``truss_damped_frf.json`` (the damped receptances of :data:`TRUSS_DAMPED_FRF`)."""
    import json
    import tempfile
    from pathlib import Path

    import numpy as np

    from .damping import complex_modes, load_damped_model
    from .damping.frf import damped_response

    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "truss_damped.toml").write_text(truss_damped_model_toml(), encoding="utf-8")
        dm = load_damped_model(Path(d) / "truss_damped.toml")
    cm = complex_modes(dm, n_modes=4)
    dofs = list(dm.model.dofs)
    modes = []
    for r in range(cm.n_modes):
        v = cm.shapes[:, r] / cm.shapes[np.argmax(np.abs(cm.shapes[:, r])), r]
        modes.append({"frequency_hz": float(cm.natural_frequencies_hz[r]), "damping_ratio": float(cm.damping_ratios[r]),
                      "shape": {d: [float(x.real), float(x.imag)] for d, x in zip(dofs, v)}})
    lo, hi, n = TRUSS_DAMPED_FRF["hz"]
    omega = 2 * np.pi * np.linspace(lo, hi, int(n))
    force = {str(TRUSS_DAMPED_FRF["force"]): 1.0}
    X, _ = damped_response(dm, omega, force, list(TRUSS_DAMPED_FRF["dofs"]))
    frf = {"omega_rad_s": omega.tolist(), "force": force,
           "response": {d: [[float(x.real), float(x.imag)] for x in X[:, k]] for k, d in enumerate(TRUSS_DAMPED_FRF["dofs"])}}
    return {"truss_damped_modes.json": json.dumps({"modes": modes}, indent=1) + "\n",
            "truss_damped_frf.json": json.dumps({"frf": frf}) + "\n"}


def _modes_object(data) -> dict:
    return {"modes": [{"eigenvalue": float(m.eigenvalue), "shape": {d: float(v) for d, v in zip(m.dofs, m.shape)}}
                      for m in data.modes]}


def example_files() -> dict[str, str]:
    """The example files ``femupdate demo --write-files DIR`` writes besides the demo's own
    (``figure2.toml``, ``figure2_test.json``, packaged with femupdate), as {name: text}.

    * ``two_dof.toml`` (Figure 3 system at k = (7, 6.5); the truth is (8, 6)),
      ``two_dof_frf.json`` (receptances at 7 lines 0.4 .. 2.8 rad/s, force at dof 1, both dofs, 0.1 % noise),
      ``two_dof_frequencies.json`` (its two natural frequencies only: two solutions),
      ``plus_2kg.toml`` and ``two_dof_plus_2kg.json`` (the same test with 2 kg added at dof 2),
      ``candidates.toml`` (modifications to rank before testing);
    * ``truss.toml`` (3-bay truss, baseline), ``truss_undamaged.json``, ``truss_damaged.json`` (member
      ``E.102-103`` has lost 40 % of its stiffness; 4 modes at every joint, 0.1 % noise),
      ``truss_damped.toml`` (the truss with Rayleigh damping and two viscous dampers,
      :data:`TRUSS_DAMPING`), ``truss_damped_modes.json`` and ``truss_damped_frf.json`` (its
      noise-free complex modes and FRFs, :func:`truss_damped_test_files`).
    """
    import json
    import tomllib

    import numpy as np

    from .damage import element_parameters
    from .damage.examples import noisy_modes
    from .updating.multiconfig import simulate as simulate_configuration
    from .updating.multiconfig.files import modification_from_dict
    from .frf.simulate import simulate
    from .modal import model_modes
    from .structure import Structure

    def dumps(obj) -> str:
        return json.dumps(obj, indent=1) + "\n"

    files = {}
    truth = two_dof()
    files["two_dof.toml"] = two_dof_model_toml()
    lines = 0.4 * np.arange(1, 8)
    d = simulate(truth, lines, {"1:x": 1.0}, noise=1e-3, seed=1)
    files["two_dof_frf.json"] = dumps({"frf": {
        "omega_rad_s": lines.tolist(), "force": {"1:x": 1.0},
        "response": {dof: np.real(d.response[:, k]).tolist() for k, dof in enumerate(d.dofs)}}})
    files["two_dof_frequencies.json"] = dumps({"modes": [{"eigenvalue": float(v)} for v in model_modes(truth).eigenvalues]})
    files["plus_2kg.toml"] = 'name = "+2 kg at dof 2"\n[[mass]]\ndofs = ["2:x"]\nm = 2.0\n'
    plus = modification_from_dict(tomllib.loads(files["plus_2kg.toml"]), "plus_2kg.toml", default_name="plus_2kg")
    files["two_dof_plus_2kg.json"] = dumps({"modes": [{"eigenvalue": float(m.eigenvalue)} for m in
                                                      simulate_configuration(truth, plus, [], n_modes=2).modes]})
    files["candidates.toml"] = ('[[candidate]]\nname = "0.5 kg at dof 2"\n[[candidate.mass]]\ndofs = ["2:x"]\nm = 0.5\n\n'
                                '[[candidate]]\nname = "2 kg at dof 1"\n[[candidate.mass]]\ndofs = ["1:x"]\nm = 2.0\n\n'
                                '[[candidate]]\nname = "2 kg at dof 2"\n[[candidate.mass]]\ndofs = ["2:x"]\nm = 2.0\n')
    files["truss.toml"] = truss_model_toml()
    files["truss_damped.toml"] = truss_damped_model_toml()
    files.update(truss_damped_test_files())
    em = element_parameters(Structure.from_dict(tomllib.loads(files["truss.toml"])))[0].build()
    joints = list(em.dofs)
    base = {TRUSS_DAMAGED: em.values[em.parameter_index(TRUSS_DAMAGED)] * (1 - TRUSS_LOSS)}
    files["truss_undamaged.json"] = dumps(_modes_object(noisy_modes(em, joints, 4, None, 1e-3, 1e-3, seed=1)))
    files["truss_damaged.json"] = dumps(_modes_object(noisy_modes(em, joints, 4, base, 1e-3, 1e-3, seed=2)))
    return files


def write_example_files(directory) -> list[str]:
    """Write :func:`example_files` into ``directory`` (atomically, one file at a time); their names.

    Parameters
    ----------
    directory : str or os.PathLike
        Destination directory (created if absent); existing files of the same names are replaced.

    Returns
    -------
    list of str
        Names of the files written, relative to ``directory``.

    Raises
    ------
    OSError
        A file cannot be written.
    """
    from pathlib import Path

    from .io.results import atomic_write_text

    directory = Path(directory)
    files = example_files()
    for name, text in files.items():
        atomic_write_text(directory / name, text)
    return list(files)
