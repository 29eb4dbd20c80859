r"""The base every rule of the modal updating problem stands on (:mod:`femupdate.rules` hands all
of it on): the marker :func:`rule` and its registry :data:`RULES`, the inner-product primitives
that compiled code replaces with implementations of their own (:func:`dot`, :func:`dot_col`,
:func:`sumsq_col`), and the error codes with their messages (:data:`ERRORS`, :func:`message`).

The rules themselves live in :mod:`femupdate.rules` and, for the pairing of test modes with
model modes, :mod:`femupdate.pairing_rules`; both import this module, and :mod:`femupdate.rules`
imports :mod:`femupdate.pairing_rules`, so that importing :mod:`femupdate.rules` registers every
rule.  This module does not import numba.
"""

from __future__ import annotations

import numpy as np

#: every function marked with :func:`rule`, in definition order
RULES: list = []


def rule(fn):
    """Mark ``fn`` as a rule of the problem: plain Python here, compiled by the compiled backend.

    Parameters
    ----------
    fn : function
        A function written in the subset of Python that numba compiles; appended to :data:`RULES`.

    Returns
    -------
    function
        ``fn`` itself, unchanged (a decorator).
    """
    RULES.append(fn)
    return fn


def dot(a, b) -> float:
    """The inner product of two vectors.  Here NumPy's; the compiled backend gives compiled code
    its own implementation, a plain sequential sum (``numba.extending.overload``).

    Parameters
    ----------
    a, b : numpy.ndarray of float, shape ``(n,)``
        The vectors.

    Returns
    -------
    float
        aᵀb.
    """
    return float(np.dot(a, b))


def dot_col(a, B, j) -> float:
    """The inner product of the vector ``a`` with column ``j`` of the matrix ``B`` (compiled: a
    sequential sum that makes no view of the column).

    Parameters
    ----------
    a : numpy.ndarray of float, shape ``(n,)``
        The vector.
    B : numpy.ndarray of float, shape ``(n, m)``
        The matrix.
    j : int
        The column, ``0 <= j < m``.

    Returns
    -------
    float
        aᵀB[:, j].
    """
    return float(np.dot(a, B[:, j]))


def sumsq_col(B, j) -> float:
    """The squared norm of column ``j`` of ``B`` (compiled: a sequential sum, no view).

    Parameters
    ----------
    B, j
        As :func:`dot_col`.

    Returns
    -------
    float
        ‖B[:, j]‖², the column's squared Euclidean norm.
    """
    return float(np.dot(B[:, j], B[:, j]))

# ---------------------------------------------------------------------------------------------
# error codes
# ---------------------------------------------------------------------------------------------
(OK, E_NONFINITE, E_MASS_DIAG, E_MASS_CHOL, E_NEGATIVE, E_NO_PAIR, E_NO_MODE_LEFT, E_NODE, E_RIGID, E_REPEATED,
 E_DEGENERATE, E_BAD_JACOBIAN) = range(12)

#: messages of the error codes; ``{k}`` and ``{k1}`` are 1-based mode numbers (or positions),
#: ``{i0}`` a count, ``{f0}``/``{f1}`` values, ``{modes}`` the 1-based test modes concerned
ERRORS = {
    E_NONFINITE: "non-finite residuals (the model became singular at these parameter values)",
    E_MASS_DIAG: "the least-squares solver failed: the mass matrix is not positive definite: a dof has no mass",
    E_MASS_CHOL: ("the least-squares solver failed: the mass matrix is not positive definite (its Cholesky "
                  "factorisation failed)"),
    E_NEGATIVE: ("the least-squares solver failed: K is not positive semi-definite: negative eigenvalue {f0:.4g} "
                 "(check for negative stiffness parameters)"),
    E_NO_PAIR: ("test mode(s) {modes} pair with no model mode (MAC below {min_mac:g} for all {i0} computed modes): "
                "check the dof labels, or lower --min-mac"),
    E_NO_MODE_LEFT: "test mode {k}: no model mode left to pair with",
    E_NODE: "cannot scale the shape to 1 at measured dof #{k}: the mode has a node there",
    E_RIGID: ("mode {k} is a rigid-body mode (zero frequency): its derivatives are not defined; differentiate the "
              "flexible modes only"),
    E_REPEATED: ("modes {k} and {k1} are repeated (eigenvalues {f0:.10g} and {f1:.10g}): eigenvector derivatives "
                 "of repeated modes are not unique; femupdate refuses rather than return a wrong derivative "
                 "(differentiate them as a group: groups= of femupdate.sensitivity.jacobian, or "
                 "femupdate.sensitivity.repeated)"),
    E_DEGENERATE: "the least-squares solver failed: the trust-region step is degenerate",
    E_BAD_JACOBIAN: "the least-squares solver failed: non-finite Jacobian",
}


def message(code: int, i0: int = 0, i1: int = 0, f0: float = 0.0, f1: float = 0.0, modes=(),
            min_mac: float = 0.5) -> str:
    """The message of error ``code`` with its numbers (``modes``: 0-based test modes).

    Parameters
    ----------
    code : int
        An error code, a key of :data:`ERRORS` (``E_NONFINITE`` ... ``E_BAD_JACOBIAN``).
    i0 : int, default 0
        0-based mode (or position) of the message, shown 1-based as ``{k}``; shown as is as
        ``{i0}`` (a count: the number of computed modes for ``E_NO_PAIR``).
    i1 : int, default 0
        0-based second mode, shown 1-based as ``{k1}`` (``E_REPEATED``).
    f0, f1 : float, default 0.0
        Values shown as ``{f0}``, ``{f1}`` (eigenvalues in rad²/s² for ``E_NEGATIVE`` and
        ``E_REPEATED``).
    modes : sequence of int, default ()
        0-based test modes concerned, shown 1-based as ``{modes}`` (``E_NO_PAIR``).
    min_mac : float, default 0.5
        The MAC threshold shown by ``E_NO_PAIR``.

    Returns
    -------
    str
        The formatted message.

    Raises
    ------
    KeyError
        ``code`` is not an error code (``OK`` has no message).
    """
    return ERRORS[int(code)].format(i0=int(i0), k=int(i0) + 1, k1=int(i1) + 1, f0=float(f0), f1=float(f1),
                                    modes=[int(k) + 1 for k in modes], min_mac=min_mac)


__all__ = ["RULES", "rule", "dot", "dot_col", "sumsq_col", "OK", "E_NONFINITE", "E_MASS_DIAG", "E_MASS_CHOL",
           "E_NEGATIVE", "E_NO_PAIR", "E_NO_MODE_LEFT", "E_NODE", "E_RIGID", "E_REPEATED", "E_DEGENERATE",
           "E_BAD_JACOBIAN", "ERRORS", "message"]
