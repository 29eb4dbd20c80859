r"""The check of a reduced answer on the full model.

At the parameters p* a start ends with, the full model's lowest modes are computed (one
factorisation of :math:`K(p^*) - \sigma M(p^*)`, shift-invert Lanczos) and compared, mode by
mode, with the reduced model's modes the answer paired with test modes:

* **frequency**: :math:`|\tilde f_j / f_j - 1| \le` ``freq_tol`` (default 1e-6);
* **shape at the data's dofs**: :math:`1 - \mathrm{MAC}(\tilde\phi_j|_S, \phi_j|_S) \le`
  ``shape_tol`` (default 1e-6);

and the a-posteriori bounds of :mod:`femupdate.rom.estimate` at p*, in the exact norm of that
factorisation, are recorded beside the true errors.  A failed check gives the modes it computed
(and their static corrections, from the same factorisation) to the basis: the reduced model is
then exact for those modes at p*, and the start is resumed from p*.
"""

from __future__ import annotations

import numpy as np

from .basis import full_modes
from .estimate import residual_bounds, ritz_pairs


def _mac(a: np.ndarray, b: np.ndarray) -> float:
    den = float(np.dot(a, a) * np.dot(b, b))
    return float(np.dot(a, b) ** 2 / den) if den > 0 else float("nan")


def check_point(rb, p: np.ndarray, model_modes, freq_tol: float = 1e-6, shape_tol: float = 1e-6, shape_dofs=None):
    """Check the reduced model of ``rb`` at ``p`` on the full model.

    Parameters
    ----------
    rb : ReducedBasis
    p : numpy.ndarray
        Every parameter's value.
    model_modes : sequence of int
        The (0-based) model modes the answer pairs with test modes.
    freq_tol, shape_tol : float
        Tolerances on the relative frequency error and on 1 − MAC at the data's dofs.
    shape_dofs : sequence of str, optional
        The dofs of the shape comparison (default the basis's data dofs).

    Returns
    -------
    (dict, tuple)
        The record (``parameters``, ``basis``, ``modes``: per mode ``model_mode`` (1-based),
        ``f_reduced_hz``, ``f_full_hz``, ``frequency_error``, ``bound_linear``,
        ``bound_quadratic``, ``one_minus_mac``, ``passed``; ``passed``) and the full modes
        ``(λ, Φ, pencil)`` for an enrichment.
    """
    from .._threads import blas_phase

    with blas_phase("solve"):
        return _check(rb, p, model_modes, freq_tol, shape_tol, shape_dofs)


def _check(rb, p, model_modes, freq_tol, shape_tol, shape_dofs):
    model = rb.model
    js = sorted({int(j) for j in model_modes}) or list(range(rb.n_modes))
    nm = max(js) + 1
    reduced, Vh = rb.reduced()
    lam_r, X = ritz_pairs(reduced, Vh, p, nm + 1)
    lam_f, Phi, pencil = full_modes(model, p, nm + 1)
    K, M, lu, sigma = pencil
    b = residual_bounds(K, M, lam_r, X, lu, sigma=sigma, n_bounded=nm)
    rows = model.dof_index(list(shape_dofs if shape_dofs is not None else rb.dofs), "data")
    out = []
    for j in js:
        f_r, f_f = np.sqrt(max(lam_r[j], 0.0)) / (2 * np.pi), np.sqrt(max(lam_f[j], 0.0)) / (2 * np.pi)
        err = abs(f_r / f_f - 1.0) if f_f > 0 else abs(f_r - f_f)
        one_minus = 1.0 - _mac(X[rows, j], Phi[rows, j]) if rows.size else 0.0
        out.append({"model_mode": j + 1, "f_reduced_hz": float(f_r), "f_full_hz": float(f_f),
                    "frequency_error": float(err), "bound_linear": float(b["linear"][j]),
                    "bound_quadratic": float(b["quadratic"][j]), "one_minus_mac": float(one_minus),
                    "passed": bool(err <= freq_tol and one_minus <= shape_tol)})
    record = {"parameters": dict(zip(model.parameter_names, map(float, p))), "basis": rb.size,
              "freq_tol": float(freq_tol), "shape_tol": float(shape_tol), "modes": out,
              "passed": all(m["passed"] for m in out)}
    return record, (lam_f, Phi, pencil)


def check_line(rec: dict) -> str:
    """One line of a check for the notes and the terminal."""
    worst_f = max((m["frequency_error"] for m in rec["modes"]), default=0.0)
    worst_s = max((m["one_minus_mac"] for m in rec["modes"]), default=0.0)
    where = (f"start {rec['start']}, " if rec.get("start") is not None else "") + f"round {rec.get('round', 1)}, "
    return (f"full-model check ({where}{len(rec['modes'])} paired modes, basis {rec['basis']}): largest frequency error "
            f"{worst_f:.2e} (tolerance {rec['freq_tol']:.0e}), largest 1-MAC at the data's dofs {worst_s:.2e} "
            f"(tolerance {rec['shape_tol']:.0e}): {'passed' if rec['passed'] else 'FAILED'}")


__all__ = ["check_point", "check_line"]
