r"""How complex a mode shape is, and its best real approximation; for model and test shapes alike.

For a shape :math:`\varphi = x + iy` (one column per mode) let

.. math::  S = \begin{bmatrix} x^Tx & x^Ty \\ x^Ty & y^Ty \end{bmatrix},
           \quad s_1 \ge s_2 \text{ its eigenvalues}.

* **MPC**, modal phase collinearity (Pappa, Elliott & Schenk, "Consistent-mode indicator for the
  eigensystem realization algorithm", J. Guidance, Control, and Dynamics 16(5), 1993), in the
  eigenvalue form of Reynders, Houbrechts & De Roeck ("Fully automated (operational) modal
  analysis", Mechanical Systems and Signal Processing 29, 2012):
  :math:`\mathrm{MPC} = ((s_1 - s_2)/(s_1 + s_2))^2` — 1 for a real (mono-phase) mode, 0 when
  the points :math:`(x_o, y_o)` show no preferred direction.
* **MPD**, mean phase deviation (Reynders et al. 2012): the mean angle, weighted by
  :math:`|\varphi_o|`, between each entry and the straight line through the origin that best
  fits the entries in the complex plane (the first right singular vector of :math:`[x\ y]`),
  in degrees — 0 for a real mode, up to 90.
* **Realisation** by phase rotation: the real vector :math:`\operatorname{Re}(e^{-i\theta}\varphi)`
  with :math:`\theta = \tfrac12 \arg \sum_o \varphi_o^2`, the rotation that maximises
  :math:`\|\operatorname{Re}(e^{-i\theta}\varphi)\|^2` (the projection onto the same best-fit
  line).  It is the simplest of the realisation methods compared by Imregun & Ewins
  ("Realisation of complex mode shapes", Proc. IMAC XI, 1993); exact for a mode that is real up
  to a common phase, and for a lightly, non-proportionally damped structure an approximation
  whose error the MPC and MPD measure.

Existing parts of femupdate that compare a complex test shape with real model shapes (the
updating targets, damage localisation, shape plots) turn it so that its largest entry is real;
:func:`realise` is the least-squares rotation, which uses every entry.
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError


def _shapes(shapes, what: str) -> tuple[np.ndarray, bool]:
    a = np.asarray(shapes)
    if a.dtype.kind not in "biufc" or a.ndim not in (1, 2) or a.size == 0:
        raise InputError(f"{what}: shapes must be a non-empty numeric vector or matrix (dofs x modes), got "
                         f"shape {a.shape}")
    a = a.astype(complex)
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what}: shapes contain NaN or infinite entries")
    return (a[:, None], True) if a.ndim == 1 else (a, False)


def modal_phase_collinearity(shapes) -> np.ndarray:
    """MPC of each mode shape (column), in [0, 1].

    Parameters
    ----------
    shapes : array_like of complex, shape ``(n_dofs,)`` or ``(n_dofs, n_modes)``

    Returns
    -------
    numpy.ndarray, shape ``(n_modes,)`` (a 0-d array for a vector)
        1 for a shape real up to a common phase.  A zero shape gives NaN.
    """
    a, vec = _shapes(shapes, "modal phase collinearity")
    x, y = a.real, a.imag
    sxx, syy, sxy = np.sum(x * x, 0), np.sum(y * y, 0), np.sum(x * y, 0)
    tr = sxx + syy
    diff = np.sqrt((sxx - syy) ** 2 + 4 * sxy ** 2)  # s1 - s2
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (diff / tr) ** 2
    return out[0] if vec else out


def mean_phase_deviation(shapes) -> np.ndarray:
    """MPD of each mode shape (column), in degrees [0, 90].

    Parameters
    ----------
    shapes : array_like of complex, shape ``(n_dofs,)`` or ``(n_dofs, n_modes)``

    Returns
    -------
    numpy.ndarray, shape ``(n_modes,)`` (a 0-d array for a vector)
    """
    a, vec = _shapes(shapes, "mean phase deviation")
    out = np.empty(a.shape[1])
    for r in range(a.shape[1]):
        phi = a[:, r]
        w = np.abs(phi)
        if not np.any(w > 0):
            out[r] = np.nan
            continue
        _, _, vt = np.linalg.svd(np.column_stack([phi.real, phi.imag]), full_matrices=False)
        d = vt[0]  # the best-fit line's direction in the complex plane
        keep = w > 0
        c = np.abs(phi.real[keep] * d[0] + phi.imag[keep] * d[1]) / w[keep]
        out[r] = np.degrees(np.sum(w[keep] * np.arccos(np.clip(c, 0.0, 1.0))) / np.sum(w[keep]))
    return out[0] if vec else out


def realise(shapes) -> np.ndarray:
    r"""Real normal-mode approximations of complex shapes by phase rotation (see the module).

    Parameters
    ----------
    shapes : array_like of complex, shape ``(n_dofs,)`` or ``(n_dofs, n_modes)``

    Returns
    -------
    numpy.ndarray of float, same shape
        :math:`\operatorname{Re}(e^{-i\theta}\varphi)` per column, the largest entry positive;
        the same scale as the complex shape (renormalise as needed).
    """
    a, vec = _shapes(shapes, "realise")
    theta = 0.5 * np.angle(np.sum(a * a, 0))
    out = (a * np.exp(-1j * theta)[None, :]).real
    k = np.argmax(np.abs(out), 0)
    out *= np.where(out[k, np.arange(out.shape[1])] < 0, -1.0, 1.0)[None, :]
    return out[:, 0] if vec else out


def data_complexity(data) -> list[dict]:
    """MPC and MPD of every measured shape of test data.

    Parameters
    ----------
    data : TestData
        Test modes (:class:`femupdate.TestData`); real shapes give MPC 1 and MPD 0.

    Returns
    -------
    list of dict
        Per test mode ``{"mode": r (1-based), "mpc": float or None, "mpd_deg": float or None}``
        (None for a mode without a shape).
    """
    out: list[dict] = []
    for r, m in enumerate(data.modes, start=1):
        if m.has_shape:
            out.append({"mode": r, "mpc": float(modal_phase_collinearity(m.shape)),
                        "mpd_deg": float(mean_phase_deviation(m.shape))})
        else:
            out.append({"mode": r, "mpc": None, "mpd_deg": None})
    return out


__all__ = ["modal_phase_collinearity", "mean_phase_deviation", "realise", "data_complexity"]
