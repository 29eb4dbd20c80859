r"""FRF residuals shared by iterative updating, residual surfaces and global search.

For model responses :math:`x_A` and measured ones :math:`x_E` at the same lines and dofs:

* ``"linear"``: :math:`w\,(x_A - x_E)` — the paper's eq. 34 (real and imaginary parts of complex
  data as separate residuals);
* ``"relative"``: :math:`w\,(x_A - x_E) / |x_E|` — every measured value counts alike, whether it
  sits on a peak or in a trough;
* ``"log"``: :math:`w\,(\ln|x_A| - \ln|x_E|)` — log-magnitude, phase ignored (usable with real
  data against a damped model and vice versa).  Undamped, :math:`\ln|x| \to -\infty` at an
  anti-resonance: a model anti-resonance cannot be moved across a measured line, so lines next
  to anti-resonances trap the iteration (keep them away, or start close).
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError

RESIDUALS = ("linear", "relative", "log")
_TINY = np.finfo(float).tiny


def check_kind(kind: str, allowed: tuple[str, ...] = RESIDUALS) -> str:
    """``kind`` if it names an FRF residual.

    Parameters
    ----------
    kind : str
        ``"linear"`` (eq. 34), ``"relative"`` or ``"log"`` (:data:`RESIDUALS`).
    allowed : tuple of str, default :data:`RESIDUALS`
        The names accepted (the updating drivers add ``"auto"``).

    Returns
    -------
    str
        ``kind`` unchanged.

    Raises
    ------
    InputError
        ``kind`` is not one of ``allowed``.
    """
    if kind not in allowed:
        raise InputError(f"unknown FRF residual {kind!r}: use {', '.join(allowed)}")
    return kind


def prepare(xe: np.ndarray, kind: str, weights, real: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Per-value weights (broadcast to ``xe``'s shape) with the ``"relative"`` scaling folded in,
    and the transformed measured values (``ln|x_E|`` for ``"log"``).  ``real``: the model's
    responses are real, so complex data are compared through their real part (the imaginary
    part is dropped here without a check; the callers refuse data with a significant one first,
    :func:`femupdate.frf.simulate.check_data_against_model`).

    Parameters
    ----------
    xe : numpy.ndarray, real or complex, shape ``(n_lines, n_dofs)``
        The measured responses x_E (any shape: the output has the same).
    kind : str
        ``"linear"``, ``"relative"`` or ``"log"`` (not checked here: see :func:`check_kind`; any
        other value acts as ``"linear"``).
    weights : float, array_like broadcastable to ``xe.shape``, or None
        Weights w >= 0 of the values; None: 1.
    real : bool, default False
        Take the real part of complex ``xe``.

    Returns
    -------
    w : numpy.ndarray of float, shape ``xe.shape``
        The weights; for ``"relative"`` divided by max(``|x_E|``, 1e-12 · max ``|x_E|``).
    target : numpy.ndarray, shape ``xe.shape``
        ln|x_E| for ``"log"``, else ``xe`` (its real part when ``real``).

    Raises
    ------
    InputError
        Non-finite or negative weights; a zero measured value with ``"log"``.
    ValueError
        ``weights`` does not broadcast to ``xe``'s shape (NumPy's error).
    """
    if real and np.iscomplexobj(xe):
        xe = xe.real
    w = np.broadcast_to(np.asarray(1.0 if weights is None else weights, float), xe.shape).copy()
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise InputError("FRF residual weights must be finite and >= 0")
    mag = np.abs(xe)
    dead = zero_channels(xe)
    if dead.any():  # a channel zero at every line (a dead sensor): left out, whatever the residual
        w[..., dead] = 0.0
    if kind == "relative":
        floor = 1e-12 * max(float(mag.max()), _TINY)
        w = w / np.maximum(mag, floor)
        w[..., dead] = 0.0
    if kind == "log":
        live = mag[..., ~dead]
        if np.any(live == 0):
            raise InputError("log-magnitude residuals need non-zero measured values (a zero response was given at "
                             "some lines of a channel that is not zero everywhere)")
        return w, np.log(np.where(mag > 0, mag, 1.0))
    return w, xe


def zero_channels(xe: np.ndarray) -> np.ndarray:
    """The response dofs (last axis) whose measured values are zero at every one of two or more
    lines (a dead channel; a single line, such as a static load case, is data whatever its value).

    Parameters
    ----------
    xe : numpy.ndarray, shape ``(n_lines, n_dofs)``
        Measured responses.

    Returns
    -------
    numpy.ndarray of bool, shape ``(n_dofs,)``
    """
    xe = np.asarray(xe)
    if xe.ndim < 2 or xe.reshape(-1, xe.shape[-1]).shape[0] < 2:
        return np.zeros(xe.shape[-1:] if xe.ndim else (0,), bool)
    return np.all(xe.reshape(-1, xe.shape[-1]) == 0, axis=0)


def values(xa: np.ndarray, target: np.ndarray, w: np.ndarray, kind: str) -> np.ndarray:
    """Residuals of model responses ``xa`` (any leading axes; trailing axes as ``target``),
    complex ones as (..., 2, lines, dofs) real and imaginary parts — flatten as needed.

    Parameters
    ----------
    xa : numpy.ndarray, real or complex, shape ``(..., n_lines, n_dofs)``
        Model responses x_A (e.g. receptances in m/N), any leading axes (points of a surface).
    target, w : numpy.ndarray, shape ``(n_lines, n_dofs)``
        From :func:`prepare`.
    kind : str
        ``"linear"``, ``"relative"`` or ``"log"``, as given to :func:`prepare`.

    Returns
    -------
    numpy.ndarray of float
        ``"log"``: w (ln max(``|x_A|``, tiny) − target), shape ``(..., n_lines, n_dofs)``; else
        w (x_A − target), real of that shape, or, when complex, shape ``(..., 2, n_lines, n_dofs)``
        (real part, then imaginary part).
    """
    if kind == "log":
        return w * (np.log(np.maximum(np.abs(xa), _TINY)) - target)
    d = w * (xa - target)
    return np.stack([d.real, d.imag], axis=-3) if np.iscomplexobj(d) else d


def jacobian(xa: np.ndarray, dxa: np.ndarray, w: np.ndarray, kind: str) -> np.ndarray:
    """``∂r/∂p`` from ``dxa = ∂x_A/∂p`` (trailing parameter axis); same layout as :func:`values`
    with the parameter axis last.

    Parameters
    ----------
    xa : numpy.ndarray, real or complex, shape ``(..., n_lines, n_dofs)``
        Model responses x_A (read only for ``"log"``).
    dxa : numpy.ndarray, real or complex, shape ``(..., n_lines, n_dofs, L)``
        Their derivatives with respect to the L parameters.
    w : numpy.ndarray, shape ``(n_lines, n_dofs)``
        Weights from :func:`prepare`.
    kind : str
        ``"linear"``, ``"relative"`` or ``"log"``.

    Returns
    -------
    numpy.ndarray of float
        ``"log"``: w Re(∂x_A / x_A) (x_A = 0 replaced by the smallest normal float), shape
        ``(..., n_lines, n_dofs, L)``; else w ∂x_A of that shape, or, when complex, shape
        ``(..., 2, n_lines, n_dofs, L)``.
    """
    if kind == "log":  # d ln|x| = Re(dx / x)
        return w[..., None] * np.real(dxa / np.where(xa == 0, _TINY, xa)[..., None])
    d = w[..., None] * dxa
    return np.stack([d.real, d.imag], axis=-4) if np.iscomplexobj(d) else d

