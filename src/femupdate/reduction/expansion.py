r"""Expansion of measured mode shapes to every model dof, with the reduction transformations.

A shape measured at the dofs ``measured_dofs`` (the retained set *a*) becomes
:math:`x = T x_a` on all model dofs, with the same ``T`` as the reduction
(:mod:`femupdate.reduction.transforms`):

* ``"guyan"``: :math:`x_o = -K_{oo}^{-1} K_{oa} x_a` (static: the omitted dofs follow the
  measured ones as under static loads there);
* ``"irs"``: Guyan plus O'Callahan's inertia correction (eqs. 41-42, corrected);
* ``"serep"``: :math:`x = \Phi \Phi_a^+ x_a`, the least-squares combination of the model's first
  ``n_modes`` modes that best fits the measurement.

Guyan and IRS keep the measured values exactly at the measured dofs; SEREP with fewer modes
than measured dofs smooths them (its :attr:`ExpandedShapes.error` is the misfit).

The paper's caution (after Tan 1993): expansion by the analytical model pulls the data toward
that model.  That is acceptable for damage detection from an already validated model, but biased
for validating the same model, so :func:`expand` warns with :class:`ExpansionBiasWarning`
unless ``warn_validation=False``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._checks import array_arg, choice_arg, count_arg, flag_arg, model_arg, strings_arg, values_arg
from .._errors import InputError
from ..dofs import canonical_all
from ..model import Model
from .reducer import Reducer

EXPANSION_METHODS = ("serep", "guyan", "irs")


class ExpansionBiasWarning(UserWarning):
    """Expansion of test data used the analytical model that the data are meant to validate."""


@dataclass(frozen=True, eq=False)
class ExpandedShapes:
    r"""Mode shapes expanded to every model dof (built by :func:`expand`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    dofs : tuple of str
        All model dofs (the rows of ``shapes``), in model order.
    shapes : ndarray (n_dofs, n_modes)
        Expanded shapes (real or complex, as given).
    method : str
        ``"serep"``, ``"guyan"`` or ``"irs"``.
    error : ndarray (n_modes,)
        Per mode, :math:`\|x_{exp,a} - x_a\| / \|x_a\|`: relative difference between the expanded
        shape at the measured dofs and the measured shape (0 for Guyan and IRS; the least-squares
        misfit for SEREP).
    measured_dofs : tuple of str
        The measured dofs, in the order of the input rows.
    n_modes : int or None
        Model modes used (SEREP).
    """

    dofs: tuple[str, ...]
    shapes: np.ndarray
    method: str
    error: np.ndarray
    measured_dofs: tuple[str, ...] = ()
    n_modes: int | None = None

    def at(self, dofs: Sequence[str]) -> np.ndarray:
        """Rows of the expanded shapes at the given dof labels.

        Parameters
        ----------
        dofs : sequence of str
            Dof labels, each a model dof.

        Returns
        -------
        numpy.ndarray, shape ``(len(dofs), n_modes)``

        Raises
        ------
        InputError
            A label that is not among :attr:`dofs`.
        """
        from ..dofs import index_of

        return self.shapes[index_of(self.dofs, dofs, "expanded shapes")]


def expand(model: Model, measured_dofs: Sequence[str], shapes: np.ndarray, method: str = "serep",
           values=None, n_modes: int | None = None, warn_validation: bool = True) -> ExpandedShapes:
    r"""Expand measured shapes to all dofs of ``model``.

    Parameters
    ----------
    model : Model
        The analytical model used for the expansion.
    measured_dofs : sequence of str
        Labels of the measured dofs (rows of ``shapes``).
    shapes : ndarray (n_measured, n_modes) or (n_measured,)
        Measured shapes, any scaling, real or complex.
    method : ``"serep"`` (default) | ``"guyan"`` | ``"irs"``
        Expansion: SEREP (a least-squares fit by the model's lowest modes) or the static
        (Guyan) or IRS transformation onto the measured dofs.
    values : None, mapping of str to float, or array_like, optional
        Parameter values of the model (default nominal).
    n_modes : int, optional
        SEREP: number of model modes in the basis, ``1 <= n_modes <= n_measured`` (default
        ``min(n_measured, number of measured shapes)``).  Ignored by Guyan and IRS.
    warn_validation : bool
        Emit :class:`ExpansionBiasWarning` (default).  Pass ``False`` when the model is an
        already validated reference, e.g. for damage detection.

    Returns
    -------
    ExpandedShapes

    Raises
    ------
    InputError
        Unknown or repeated dofs, a shape array that does not match them, NaN, an unknown method,
        too many SEREP modes, a singular omitted partition (Guyan/IRS; the mechanism is named).
    """
    model_arg(model, "model", "expand")
    if not isinstance(measured_dofs, str) and not strings_arg(measured_dofs, "measured_dofs", "expand", optional=False,
                                                              what="dof label"):
        raise InputError("expand: measured_dofs is empty (give the labels of the measured dofs)")
    array_arg(shapes, "shapes", "expand", complex_ok=True, finite=False)
    choice_arg(method, EXPANSION_METHODS, "method", "expand")
    values_arg(model, values, "values", "expand")
    n_measured = 1 if isinstance(measured_dofs, str) else len(measured_dofs)
    if (count_arg(n_modes, "n_modes", "expand", optional=True) or 0) > n_measured:
        raise InputError(f"expand: n_modes: {n_modes} modes for {n_measured} retained dofs (the measured dofs): use at "
                         f"most {n_measured}")
    flag_arg(warn_validation, "warn_validation", "expand")
    method = str(method).lower()
    if method not in EXPANSION_METHODS:
        raise InputError(f"expand: unknown method {method!r}: use {', '.join(EXPANSION_METHODS)}")
    if isinstance(measured_dofs, str):
        measured_dofs = [measured_dofs]
    measured = canonical_all(measured_dofs, "measured dofs")
    X = np.asarray(shapes)
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2 or X.shape[0] != len(measured):
        raise InputError(f"expand: shapes must have shape ({len(measured)}, n_modes) (one row per measured dof), got {np.shape(shapes)}")
    if X.shape[1] == 0:
        raise InputError("expand: no shapes given")
    X = X.astype(complex if np.iscomplexobj(X) else float)
    if not np.all(np.isfinite(X)):
        raise InputError("expand: shapes contain NaN or infinite values")
    norms = np.linalg.norm(X, axis=0)
    if np.any(norms == 0):
        raise InputError(f"expand: shape(s) {(np.flatnonzero(norms == 0) + 1).tolist()} are zero at every measured dof")
    red = Reducer(model, measured, values)
    used = None
    if method == "guyan":
        full = np.empty((model.n_dofs, X.shape[1]), dtype=X.dtype)
        full[red.ia] = X
        if red.io.size:
            K_oa = red._block(red.K, red.io, red.ia)
            rhs = K_oa @ X
            full[red.io] = -(_solve_any(red, rhs))
    elif method == "irs":
        full = red.irs().T @ X
    else:
        used = red._n_modes(n_modes, "serep", default=min(red.n_keep, X.shape[1]))
        phi = red.modes(used).shapes
        pinv = red._phi_a_pinv(phi[red.ia], "serep expansion")
        full = phi @ (pinv @ X)
    if warn_validation:
        warnings.warn(
            f"expand ({method}): the measured shapes were expanded with the analytical model itself, which pulls "
            "them toward that model; acceptable for damage detection from a validated model, biased for "
            "validating this model (pass warn_validation=False to silence)", ExpansionBiasWarning, stacklevel=2)
    err = np.linalg.norm(full[red.ia] - X, axis=0) / norms
    return ExpandedShapes(model.dofs, full, method, err, measured, used)


def _solve_any(red: Reducer, B: np.ndarray) -> np.ndarray:
    """K_oo^{-1} B for real or complex B with the reducer's one factorisation."""
    if np.iscomplexobj(B):
        return red.solve_oo(B.real) + 1j * red.solve_oo(B.imag)
    return red.solve_oo(B)
