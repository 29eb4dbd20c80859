r"""Pretest correlation of a plan: the test-analysis model (TAM) on the chosen dofs, its
orthogonality checks, and the mass loading of the accelerometers.

* **TAM** — the model reduced to the measured dofs a by a transformation of
  :mod:`femupdate.reduction` (:math:`K_{TAM} = T^T K T`, :math:`M_{TAM} = T^T M T`):
  ``"guyan"`` (static condensation), ``"irs"`` (Improved Reduced System) or ``"serep"``, built
  here from the target modes, :math:`T = \Phi_t \Phi_{t,a}^+`, so that it reproduces the target
  modes and their frequencies exactly.  Reported: the TAM's frequencies paired with the full
  model's target modes (relative error), the **self-orthogonality**
  :math:`\Phi_{t,a}^T M_{TAM} \Phi_{t,a}` of the target modes at the sensors (normalised; the test
  lab checks measured modes this way, off-diagonal terms held to 0.1), and the
  **cross-orthogonality** :math:`\Psi^T M_{TAM} \Phi_{t,a}` of the TAM's own modes Ψ against the
  full model's (1 on the diagonal when the TAM reproduces them).
* **Mass loading** — an accelerometer of mass m_s on each sensor, added to every translation of its
  node (a uniaxial accelerometer still has its mass in all directions; two uniaxial sensors at a
  node add two masses): the frequency shifts, exactly by re-solving :math:`(K, M + \Delta M)` and
  to first order by the eigenvalue sensitivity of mass-normalised modes,
  :math:`\Delta\lambda_r \approx -\lambda_r\,\phi_r^T \Delta M \phi_r`, i.e.
  :math:`\Delta f_r / f_r \approx -\tfrac12 \phi_r^T \Delta M \phi_r`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..dofs import parse_dof
from ..modal import solve_modes

TAM_METHODS = ("guyan", "irs", "serep")


def tam(model, dofs: Sequence[str], target_shapes: np.ndarray, target_eigenvalues: np.ndarray, method: str = "guyan",
        values=None) -> dict:
    """The test-analysis model on ``dofs`` and its orthogonality checks (module docstring).

    Parameters
    ----------
    model : Model
    dofs : sequence of str
        The measured dofs (the TAM's a-set), distinct.
    target_shapes : ndarray, shape ``(n_dofs, m)``
        The full model's mass-normalised target modes at every dof.
    target_eigenvalues : ndarray, shape ``(m,)``
        Their eigenvalues (rad²/s²).
    method : {"guyan", "irs", "serep"}
    values : optional
        Parameter values (default nominal).

    Returns
    -------
    dict
        ``method``, ``dofs``, ``full_frequencies_hz``, ``tam_frequencies_hz`` (paired by the
        largest total MAC with the target modes; NaN for a target left unpaired when the TAM has
        fewer dofs than target modes), ``frequency_error`` (relative), ``mac``, ``paired_targets``,
        ``self_orthogonality`` (m × m), ``self_max_offdiag``, ``cross_orthogonality`` (absolute values, paired
        TAM modes × paired target modes), ``cross_min_diag``, ``cross_max_offdiag``.

    Raises
    ------
    InputError
        An unknown method; as the reduction (a singular omitted partition, a massless a-set,
        sensors that do not tell the target modes apart).
    """
    from ..reduction import Reducer, Transformation, orthogonality
    from ..reduction.projection import reduced_matrices, reduced_modes

    if method not in TAM_METHODS:
        raise InputError(f"unknown TAM method {method!r}: use {', '.join(TAM_METHODS)}")
    keep = list(dict.fromkeys(dofs))
    red = Reducer(model, keep, values)
    Phi = np.asarray(target_shapes, float)
    lam = np.asarray(target_eigenvalues, float)
    if method == "serep":
        pinv = red._phi_a_pinv(Phi[red.ia], "serep TAM")
        t = Transformation(Phi @ pinv, model.dofs, tuple(red.keep), "serep", red.values.copy(), Phi.shape[1])
    else:
        t = red.transformation(method)
    Kr, Mr = reduced_matrices(model, t)
    lam_r, Psi = reduced_modes(Kr, Mr)
    Pa = Phi[red.ia]
    # pair the target modes with the TAM's modes by the largest total MAC (a TAM of a < m dofs
    # has fewer modes: the unpaired targets are reported as such)
    G = Psi.T @ Mr @ Pa
    mac = G ** 2 / np.outer(np.einsum("ij,ij->j", Psi, Mr @ Psi), np.einsum("ij,ij->j", Pa, Mr @ Pa))
    from scipy.optimize import linear_sum_assignment

    r_idx, c_idx = linear_sum_assignment(-mac)
    m = Pa.shape[1]
    pick = np.full(m, -1)
    pick[c_idx] = r_idx
    paired = pick >= 0
    f_full = np.sqrt(np.abs(lam)) / (2 * np.pi)
    f_tam = np.full(m, np.nan)
    f_tam[paired] = np.sqrt(np.abs(lam_r[pick[paired]])) / (2 * np.pi)
    self_o = orthogonality(Pa, Pa, Mr)
    cross = np.abs(orthogonality(Psi[:, pick[paired]], Pa[:, paired], Mr))
    off = self_o - np.diag(np.diag(self_o))
    cross_off = cross - np.diag(np.diag(cross))
    return {"method": method, "dofs": list(red.keep), "full_frequencies_hz": f_full, "tam_frequencies_hz": f_tam,
            "frequency_error": (f_tam - f_full) / f_full,
            "mac": np.array([mac[p, j] if p >= 0 else 0.0 for j, p in enumerate(pick)]),
            "paired_targets": [int(j) for j in np.flatnonzero(paired)], "self_orthogonality": self_o,
            "self_max_offdiag": float(np.max(np.abs(off))) if off.size else 0.0, "cross_orthogonality": cross,
            "cross_min_diag": float(np.min(np.diag(cross))) if cross.size else float("nan"),
            "cross_max_offdiag": float(np.max(cross_off)) if cross_off.size else 0.0}


def sensor_mass_matrix(model, sensors: Sequence[Sequence[str]], mass: float) -> sp.csr_array:
    """ΔM of the accelerometers: ``mass`` (kg) per sensor on every translation of its node."""
    if not (np.isfinite(mass) and mass >= 0):
        raise InputError(f"sensor mass must be a finite number >= 0 kg, got {mass!r}")
    by_node: dict[str, list[int]] = {}
    for i, d in enumerate(model.dofs):
        node, direction = parse_dof(d)
        if direction in ("x", "y", "z"):
            by_node.setdefault(str(node), []).append(i)
    diag = np.zeros(model.n_dofs)
    for s in sensors:
        node = str(parse_dof(s[0])[0])
        rows = by_node.get(node) or list(model.dof_index(list(s), "sensors"))
        diag[rows] += mass
    return sp.csr_array(sp.diags_array(diag))


def mass_loading(model, sensors: Sequence[Sequence[str]], mass: float, target: Sequence[int], values=None) -> dict:
    """Frequency shifts of the target modes caused by an accelerometer mass per sensor.

    Parameters
    ----------
    model : Model
    sensors : sequence of sequence of str
        The plan's sensors (each its dofs).
    mass : float
        Mass of one sensor, kg (>= 0).
    target : sequence of int
        Target modes (0-based).
    values : optional

    Returns
    -------
    dict
        ``sensor_mass`` (kg), ``total_mass`` (kg), ``frequencies_hz`` (unloaded),
        ``loaded_frequencies_hz`` (re-solved; paired by MAC), ``shift_hz``, ``relative_shift``
        (exact) and ``first_order_relative_shift`` (:math:`-\\tfrac12\\phi^T\\Delta M\\phi`),
        ``mac`` of each pair (loaded against unloaded, over all dofs).

    Raises
    ------
    InputError
        A negative or non-finite mass.
    NumericalError
        An eigen-solution fails.
    """
    p = model.resolve(values)
    K, M = model.K(p), model.M(p)
    dM = sensor_mass_matrix(model, sensors, mass)
    which = np.asarray(target, dtype=int)
    n = min(model.n_dofs, max(int(which.max()) + 1 + 6, 2 * (int(which.max()) + 1)))
    base = solve_modes(K, M, n_modes=n, dofs=model.dofs)
    loaded = solve_modes(K, M + dM, n_modes=n, dofs=model.dofs)
    Phi = base.shapes[:, which]
    G = loaded.shapes.T @ (M @ Phi)
    mac = G ** 2 / np.outer(np.einsum("ij,ij->j", loaded.shapes, M @ loaded.shapes), np.einsum("ij,ij->j", Phi, M @ Phi))
    from scipy.optimize import linear_sum_assignment

    rows, cols = linear_sum_assignment(-mac)
    pair = rows[np.argsort(cols)]
    f0 = base.frequencies_hz[which]
    f1 = loaded.frequencies_hz[pair]
    first = -0.5 * np.einsum("ij,ij->j", Phi, dM @ Phi)
    return {"sensor_mass": float(mass), "total_mass": float(dM.diagonal().sum()), "n_sensors": len(sensors),
            "frequencies_hz": f0, "loaded_frequencies_hz": f1, "shift_hz": f1 - f0, "relative_shift": (f1 - f0) / f0,
            "first_order_relative_shift": first, "mac": mac[pair, np.arange(which.size)]}


__all__ = ["TAM_METHODS", "tam", "mass_loading", "sensor_mass_matrix"]
