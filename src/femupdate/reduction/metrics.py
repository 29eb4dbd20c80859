r"""Accuracy and robustness of a reduced (test-analysis) model, as defined by Tan (1993).

* **Accuracy** — how well the reduced model reproduces the full model: natural frequencies of the
  reduced model against the full model's, MAC between the reduced modes and the full modes at the
  retained dofs, and the pseudo-orthogonality :math:`\phi_{a}^T M_r \phi_{a}` of the full model's
  modes (restricted to the retained dofs) with the reduced mass.
* **Robustness** — how reliable the reduced mass is as a yardstick for *test* modes, which come
  from the real (different) structure: the self-orthogonality :math:`\phi_t^T M_r \phi_t` (test vs
  test) and the cross-orthogonality :math:`\phi_t^T M_r \phi_a` (test vs analysis).

Every orthogonality matrix is normalised, :math:`O_{ij} = x_i^T M_r y_j / \sqrt{(x_i^T M_r x_i)
(y_j^T M_r y_j)}`, so that its diagonal is 1 for the self-orthogonality and its off-diagonal
terms are the ones usually held to 0.1 (10 %) in TAM practice.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..correlation import mac, pair
from .projection import Transformation, reduced_matrices, reduced_modes


def orthogonality(A: np.ndarray, B: np.ndarray, M: np.ndarray) -> np.ndarray:
    r"""Normalised orthogonality :math:`a_i^T M b_j / \sqrt{(a_i^T M a_i)(b_j^T M b_j)}`, (ma, mb).

    Parameters
    ----------
    A : array_like, shape ``(n, ma)``
        First set of shapes (complex parts dropped when negligible).
    B : array_like, shape ``(n, mb)``
        Second set, on the same dofs.
    M : array_like or sparse matrix, shape ``(n, n)``
        Mass matrix (kg) on those dofs.

    Returns
    -------
    numpy.ndarray, shape ``(ma, mb)``
        Normalised products; 0 where a norm is zero.
    """
    A = np.real_if_close(np.asarray(A))
    B = np.real_if_close(np.asarray(B))
    num = A.T @ M @ B
    da = np.sqrt(np.abs(np.einsum("ij,ij->j", A, M @ A)))
    db = np.sqrt(np.abs(np.einsum("ij,ij->j", B, M @ B)))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = num / np.outer(da, db)
    return np.where(np.isfinite(out), out, 0.0)


def _offdiag_max(O: np.ndarray) -> float:
    if O.shape[0] < 2 and O.shape[1] < 2:
        return 0.0
    X = np.abs(O).copy()
    k = min(X.shape)
    X[np.arange(k), np.arange(k)] = 0.0
    return float(X.max())


@dataclass(frozen=True, eq=False)
class TamMetrics:
    """Tan's accuracy and robustness figures of one reduced model.

    Accuracy: ``full_frequencies_hz``, ``reduced_frequencies_hz`` (paired by MAC),
    ``frequency_error`` (relative, reduced − full), ``mac`` (per pair), ``pseudo_orthogonality``
    (full modes at the retained dofs with the reduced mass).  Robustness (only with test shapes):
    ``self_orthogonality`` (test vs test), ``cross_orthogonality`` (test vs full-model modes,
    rows and columns paired by MAC).  The ``*_max_offdiag`` and ``cross_min_diag`` numbers
    summarise them.

    Parameters
    ----------
    method : str
        The transformation's method (:attr:`Transformation.method`).
    keep : tuple of str
        Retained dof labels.
    full_frequencies_hz : numpy.ndarray, shape ``(m,)``
        The full model's lowest m natural frequencies, Hz.
    reduced_frequencies_hz : numpy.ndarray, shape ``(m,)``
        The reduced model's frequency paired with each, Hz (NaN if unpaired).
    frequency_error : numpy.ndarray, shape ``(m,)``
        (reduced − full) / full (the absolute difference where the full frequency is 0; ``inf``
        where unpaired).
    mac : numpy.ndarray, shape ``(m,)``
        MAC of each pair (0 if unpaired).
    pseudo_orthogonality : numpy.ndarray, shape ``(m, m)``
        :func:`orthogonality` of the full modes at ``keep`` with the reduced mass.
    self_orthogonality : numpy.ndarray, shape ``(m_t, m_t)``, optional
        Of the test shapes with themselves (None without test shapes).
    cross_orthogonality : numpy.ndarray, optional
        Of the test shapes (rows) with the full modes paired to them by MAC (columns).
    """

    method: str
    keep: tuple[str, ...]
    full_frequencies_hz: np.ndarray
    reduced_frequencies_hz: np.ndarray
    frequency_error: np.ndarray
    mac: np.ndarray
    pseudo_orthogonality: np.ndarray
    self_orthogonality: np.ndarray | None = None
    cross_orthogonality: np.ndarray | None = None

    @property
    def max_frequency_error(self) -> float:
        """Largest ``|frequency_error|``."""
        return float(np.max(np.abs(self.frequency_error)))

    @property
    def min_mac(self) -> float:
        """Smallest MAC of a pair."""
        return float(np.min(self.mac))

    @property
    def pseudo_max_offdiag(self) -> float:
        """Largest ``|off-diagonal|`` of the pseudo-orthogonality (0 for a 1 × 1 matrix)."""
        return _offdiag_max(self.pseudo_orthogonality)

    @property
    def self_max_offdiag(self) -> float | None:
        """Largest ``|off-diagonal|`` of the self-orthogonality (None without test shapes)."""
        return None if self.self_orthogonality is None else _offdiag_max(self.self_orthogonality)

    @property
    def cross_max_offdiag(self) -> float | None:
        """Largest ``|off-diagonal|`` of the cross-orthogonality (None without test shapes)."""
        return None if self.cross_orthogonality is None else _offdiag_max(self.cross_orthogonality)

    @property
    def cross_min_diag(self) -> float | None:
        """Smallest ``|diagonal|`` of the cross-orthogonality (None without test shapes)."""
        if self.cross_orthogonality is None:
            return None
        return float(np.min(np.abs(np.diag(self.cross_orthogonality))))

    def summary(self) -> dict:
        """The method and the summary numbers as a dict (None for the robustness ones without test shapes)."""
        return {
            "method": self.method,
            "max_frequency_error": self.max_frequency_error, "min_mac": self.min_mac,
            "pseudo_orthogonality_max_offdiag": self.pseudo_max_offdiag,
            "self_orthogonality_max_offdiag": self.self_max_offdiag,
            "cross_orthogonality_min_diag": self.cross_min_diag,
            "cross_orthogonality_max_offdiag": self.cross_max_offdiag,
        }


def tam_metrics(model, t: Transformation, n_modes: int | None = None, test_shapes: np.ndarray | None = None,
                full_modes=None) -> TamMetrics:
    r"""Accuracy (and, with test shapes, robustness) of the reduced model built with ``t``.

    Parameters
    ----------
    model : Model
        The full analytical model ``t`` was built on.
    t : Transformation
    n_modes : int, optional
        Number of the full model's lowest modes to compare (default ``min(a, 10)``).
    test_shapes : ndarray (a, m_t), optional
        Measured shapes at ``t.keep`` (rows in that order) — from the real, different structure.
    full_modes : Modes, optional
        The full model's modes at ``t.values`` (computed when not given).

    Returns
    -------
    TamMetrics

    Raises
    ------
    InputError
        ``n_modes`` not between 1 and ``len(t.keep)``, fewer ``full_modes`` than ``n_modes``, or
        test shapes not of shape ``(len(t.keep), m_t)``.
    """
    from ..modal import model_modes

    a = len(t.keep)
    m = min(a, 10) if n_modes is None else int(n_modes)
    if not 1 <= m <= a:
        raise InputError(f"tam_metrics: n_modes must be between 1 and the {a} retained dofs, got {m}")
    fm = full_modes if full_modes is not None else model_modes(model, t.values, n_modes=min(model.n_dofs, m))
    if fm.n_modes < m:
        raise InputError(f"tam_metrics: {fm.n_modes} full-model modes given, {m} needed")
    ia = t.keep_index
    phi_a = fm.shapes[ia, :m]
    K_r, M_r = reduced_matrices(model, t)
    lam_r, V = reduced_modes(K_r, M_r)
    MAC = mac(phi_a, V)
    pairs = pair(MAC, rule="mac", min_mac=0.0).pairs  # every one of the m full-model modes (m <= a)
    f_full = fm.frequencies_hz[:m]
    f_red = np.full(m, np.nan)
    macs = np.zeros(m)
    for i, j, v in pairs:
        f_red[i] = np.sqrt(max(lam_r[j], 0.0)) / (2 * np.pi)
        macs[i] = v
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where(f_full > 0, (f_red - f_full) / np.where(f_full > 0, f_full, 1.0), f_red - f_full)
    err = np.where(np.isfinite(err), err, np.inf)
    pseudo = orthogonality(phi_a, phi_a, M_r)
    self_o = cross = None
    if test_shapes is not None:
        X = np.asarray(test_shapes)
        if X.ndim != 2 or X.shape[0] != a:
            raise InputError(f"tam_metrics: test shapes must have shape ({a}, m) (rows = retained dofs), got {X.shape}")
        X = np.real(X) if not np.iscomplexobj(X) else np.real(X * np.exp(-1j * np.angle(X[np.argmax(np.abs(X), axis=0), np.arange(X.shape[1])])))
        self_o = orthogonality(X, X, M_r)
        tp = pair(mac(X, phi_a), rule="mac", min_mac=0.0).pairs
        rows = [i for i, _, _ in tp]
        cols = [j for _, j, _ in tp]
        cross = orthogonality(X[:, rows], phi_a[:, cols], M_r)
    return TamMetrics(t.method, t.keep, f_full, f_red, err, macs, pseudo, self_o, cross)
