r"""Many updating problems of one model solved as one batch: every (case, start) pair a row.

A uniqueness study updates one model from many measurement plans (cases: measured dofs × number
of modes) and many random starts.  :class:`StudyProblem` gives every row — whatever its case,
noise realisation or start — its own data set on one shared model, and :meth:`StudyProblem.solve`
runs all rows through the compiled solver (:func:`femupdate.batch.solve_compiled`: residuals,
Jacobians and SciPy's trf per row in compiled code, rows in parallel), each row with exactly its
own residuals, so its decisions are those of :func:`femupdate.updating.update` for that case from
that start.

The NumPy residuals below (``evaluate``/``jacobian``, used by ``solve(compiled=False)`` and for
checks) keep a padded layout:

Residual layout (padded and masked).  With T the most test modes of any row and U the union of
the measured dofs (u = |U|), every row has T blocks of 1 + u entries: per test mode k its
relative eigenvalue error, then its unit-length scaled shape difference at the dofs of U.
Entries a row does not measure (test modes beyond its own, dofs outside its set, every shape
entry of a one-sensor row) are zero in the residual and in the Jacobian, so that a row's cost,
gradient, Gauss–Newton step and trust-region decisions are those of its own unpadded problem —
the one :func:`femupdate.updating.update` solves for that case from that start.  SciPy's rank
test uses the number of residuals (``eps·m·σ_max``), so each row passes its own count
(``n_residuals`` of :func:`~femupdate.batch.least_squares_batch`).

Per row everything follows ``updating._Problem``: unit-length scaling over the row's measured
dofs with the sign aligned to the test shape; shapes at fewer than two dofs carry no information
and are dropped (frequencies only, test mode k paired with model mode k); otherwise pairing by
MAC on the row's measured dofs with the Hungarian algorithm over the ``min(N, buffered_modes(T_row))``
lowest modes, a test mode below ``min_mac`` failing the start; exact Jacobians by Fox–Kapoor
(eq. 21) and the complete modal method (all modes are available from ``eigh``), as
:mod:`femupdate.batch`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .._errors import InputError
from ..batch import BatchProblem, _distinct_errors, _Evaluation, _reject_nonfinite
from ..sensitivity.subspace import buffered_modes
from ..testdata import MeasuredMode, TestData


@dataclass(frozen=True, eq=False)
class RowData:
    """Per-row test data, padded: ``lam_e`` (B, T) measured eigenvalues (1 where padded);
    ``psi_e`` (B, u, T) unit-length test shapes on the sensor union (0 where not measured);
    ``smask`` (B, u) the row's measured dofs among the sensors (all False for one-sensor rows);
    ``n_test`` (B,) the row's number of test modes; ``sensors`` (u,) model dof indices."""

    lam_e: np.ndarray
    psi_e: np.ndarray
    smask: np.ndarray
    n_test: np.ndarray
    sensors: np.ndarray


class StudyProblem(BatchProblem):
    """Residuals and exact Jacobians of every row of a study at once (see the module notes).

    Parameters
    ----------
    model : Model
    names : updated parameters.
    rows : RowData
    starts : (B, L) starting values, physical units, one per row.
    values : values of the parameters not updated (and the truth, for the template).
    min_mac, max_nfev, ftol, xtol, gtol : as :func:`femupdate.updating.update`.

    The model-level set-up (dense matrix stacks, supports, Cholesky factor of a fixed mass matrix,
    starting points and bounds in the relative variables x = p / |p_start|) is
    :class:`~femupdate.batch.BatchProblem`'s; evaluation, pairing and Jacobians are per row here.
    """

    def __init__(self, model, names, rows: RowData, starts, *, values=None, min_mac: float = 0.5,
                 max_nfev: int = 200, ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10):
        from ..modal import model_modes

        # a template data set for BatchProblem's model-level set-up only (the rows' own data are in
        # ``rows``): a flexible mode measured at every dof gives N data, ceil(L / N) of them suffice
        mm = model_modes(model, values)
        flex = [j for j in range(mm.n_modes) if mm.eigenvalues[j] > 0][: max(1, -(-len(names) // model.n_dofs))]
        template = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], model.dofs, mm.shapes[:, j]) for j in flex))
        super().__init__(model, template, names, starts, values=values, min_mac=min_mac, max_nfev=max_nfev,
                         ftol=ftol, xtol=xtol, gtol=gtol, shape_scaling="unit", parametrisation="relative")
        B = np.asarray(starts).shape[0]
        if rows.lam_e.shape[0] != B:
            raise InputError(f"{rows.lam_e.shape[0]} rows of data for {B} starts")
        self.rows = rows
        self.T = rows.lam_e.shape[1]
        self.U = np.asarray(rows.sensors, dtype=np.intp)
        self.u = self.U.size
        self.n_test_row = np.asarray(rows.n_test, dtype=np.intp)
        self.tmask = np.arange(self.T)[None, :] < self.n_test_row[:, None]
        self.has_shape = rows.smask.sum(axis=1) >= 2
        self.smask = rows.smask & self.has_shape[:, None]
        self.nm_row = np.array([min(self.n, buffered_modes(int(t))) for t in self.n_test_row], dtype=np.intp)
        self.nm = int(self.nm_row.max())  # BatchProblem._modes' rigid/definiteness checks
        self.n_residuals = self.T * (1 + self.u)
        self.own_residuals = self.n_test_row * (1 + self.smask.sum(axis=1))
        self.n_test = self.T

    # ------------------------------------------------------------------ the compiled route
    def datasets(self):
        """Each row's own data set, as the flat arrays of :func:`femupdate._modal.data_arrays`
        (unit-length test shapes at the row's measured dofs, in ascending dof order; none for
        one-sensor rows; weights 1), built without a loop over rows."""
        B, T = self.rows.lam_e.shape
        nt = self.n_test_row.astype(np.int64)
        ns = self.smask.sum(axis=1).astype(np.int64)  # 0 for one-sensor rows (smask cleared)
        real = self.tmask  # (B, T)
        lam_e = self.rows.lam_e[real]
        q_ns = np.broadcast_to(ns[:, None], (B, T))[real]  # positions of each test mode
        pptr = np.concatenate([[0], np.cumsum(q_ns)]).astype(np.int64)
        sel = real[:, None, :] & self.smask[:, :, None]  # (B, u, T): measured (dof, mode) pairs
        order = np.transpose(sel, (0, 2, 1))  # (B, T, u): per mode its dofs, ascending
        pos = np.broadcast_to(self.U[None, None, :], order.shape)[order].astype(np.int64)
        psi_e = np.transpose(self.rows.psi_e, (0, 2, 1))[order]
        ds_t0 = np.concatenate([[0], np.cumsum(nt)[:-1]]).astype(np.int64)
        ds_m = nt * (1 + ns)
        return (ds_t0, nt, self.nm_row.astype(np.int64), ds_m, lam_e, np.ones(lam_e.size), pptr, pos, psi_e,
                np.full(lam_e.size, -1, np.int64))

    def row_datasets(self):
        return np.arange(self.R, dtype=np.int64)

    def solve(self, progress=None, compiled: bool = True):
        """Every row to the end, compiled (default), or round by round with the NumPy residuals."""
        from ..batch import solve_compiled

        if compiled:
            return solve_compiled(self, self.datasets(), self.row_datasets(), progress=progress, history=False)
        return super().solve(progress=progress, compiled=False)

    # ------------------------------------------------------------------ evaluation
    def _pair_rows(self, lam, Phi, rows, ok, errors):
        """Pairs (S, T) and MACs by ``_Problem._pair``'s rules, row by row in one go."""
        S, n, T = lam.shape[0], self.n, self.T
        pairs = np.tile(np.arange(T), (S, 1))  # frequencies only: the lowest modes in order
        macs = np.full((S, T), np.nan)
        sh = np.flatnonzero(self.has_shape[rows] & ok)
        if sh.size == 0:
            return pairs, macs
        r_sh = rows[sh]
        sm = self.smask[r_sh]  # (s, u)
        Bm = np.where(sm[:, :, None], Phi[sh][:, self.U, :], 0.0)  # (s, u, n)
        pe = self.rows.psi_e[r_sh]  # (s, u, T)
        num = np.einsum("sut,suj->stj", pe, Bm) ** 2
        den = np.sum(pe**2, axis=1)[:, :, None] * np.einsum("suj,suj->sj", Bm, Bm)[:, None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            M = np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0), 0.0, 1.0)
        nm = self.nm_row[r_sh]
        M = np.where(np.arange(n)[None, None, :] < nm[:, None, None], M, 0.0)  # modes not computed
        real = self.tmask[r_sh]  # (s, T)
        best = np.argmax(M, axis=2)
        top = np.take_along_axis(M, best[:, :, None], axis=2)[:, :, 0]
        M2 = M.copy()
        np.put_along_axis(M2, best[:, :, None], -np.inf, axis=2)
        strict = np.all((top > np.max(M2, axis=2)) | ~real, axis=1) if n > 1 else np.ones(sh.size, bool)
        key = np.where(real, best, n + np.arange(T)[None, :])  # padded modes never collide
        srt = np.sort(key, axis=1)
        distinct = np.all(srt[:, 1:] != srt[:, :-1], axis=1) if T > 1 else np.ones(sh.size, bool)
        low = (top < self.min_mac) & real  # below min_mac for every model mode: no assignment can pair it
        fast = strict & distinct & ~low.any(axis=1)
        pairs[sh[fast]] = np.where(real[fast], best[fast], np.arange(T)[None, :])
        macs[sh[fast]] = np.where(real[fast], top[fast], np.nan)
        slow = np.flatnonzero(~fast & ~low.any(axis=1))  # the Hungarian algorithm, one call per row
        nts = self.n_test_row[r_sh]
        cc = np.tile(np.arange(T), (slow.size, 1))
        for j, i in enumerate(slow):
            cc[j, :nts[i]] = linear_sum_assignment(M[i, :nts[i], :nm[i]], maximize=True)[1]  # rows in order
        got = np.take_along_axis(M[slow], cc[:, :, None], axis=2)[:, :, 0]
        short = (got < self.min_mac) & real[slow]
        good = ~short.any(axis=1)
        pairs[sh[slow[good]]] = cc[good]
        macs[sh[slow[good]]] = np.where(real[slow[good]], got[good], np.nan)
        low[slow[~good]] = short[~good]
        for i in np.flatnonzero(low.any(axis=1)):
            r = sh[i]
            errors[r] = (f"NumericalError: test mode(s) {(np.flatnonzero(low[i]) + 1).tolist()} pair with no model mode "
                         f"(MAC below {self.min_mac:g} for all {nm[i]} computed modes): check the dof labels, or lower --min-mac")
            ok[r] = False
        return pairs, macs

    def _unit_shapes(self, Phi, pairs, rows):
        """Model shapes of the paired modes on the sensors, masked (S, u, T); their unit-length
        scale ``s`` (S, T) with the sign of the largest entry; ψ = shape / s; the sign (±1) aligning
        ψ with the test shape; and the mask (S, u, T) as floats."""
        S = Phi.shape[0]
        mask = (self.smask[rows][:, :, None] & self.tmask[rows][:, None, :]).astype(float)
        Ps = Phi[np.arange(S)[:, None, None], self.U[None, :, None], pairs[:, None, :]] * mask
        k = np.argmax(np.abs(Ps), axis=1)
        big = np.take_along_axis(Ps, k[:, None, :], axis=1)[:, 0, :]
        s = np.sign(big) * np.sqrt(np.einsum("sut,sut->st", Ps, Ps))
        s[~mask.any(axis=1)] = 1.0
        psi = Ps / s[:, None, :]
        flip = np.where(np.einsum("sut,sut->st", psi, self.rows.psi_e[rows]) < 0, -1.0, 1.0)
        return Ps, psi, s, flip, mask

    def evaluate(self, X, rows=None) -> _Evaluation:
        """Eigen-solutions, pairs and padded residuals (S, T(1 + u)) at solver variables X (S, L)."""
        X, rows, errors, ok = self._begin_evaluation(X, rows)
        S = X.shape[0]
        with np.errstate(all="ignore"):
            lam, Phi = self._modes_of_rows(self.to_p(X, rows), errors, ok)
            pairs, macs = self._pair_rows(lam, Phi, rows, ok, errors)
            lam_e = self.rows.lam_e[rows]
            lam_p = np.take_along_axis(lam, pairs, axis=1)
            shapes = self._unit_shapes(Phi, pairs, rows)
            _, psi, _, flip, mask = shapes
            F = np.concatenate([(self.tmask[rows] * ((lam_p - lam_e) / lam_e))[:, :, None],
                                ((psi * flip[:, None, :] - self.rows.psi_e[rows]) * mask).transpose(0, 2, 1)], axis=2)
            F = F.reshape(S, -1)
        _reject_nonfinite(F, ok, errors)
        F[~ok] = 0.0
        ev = _Evaluation(rows, X, lam, Phi, pairs, macs, F, errors)
        ev.shapes = shapes  # reused by the Jacobian at this point
        return ev

    def _check_distinct_rows(self, lam, pairs, rows):
        """``check_distinct`` on each row's paired modes among its computed ones: error or None."""
        computed = np.arange(lam.shape[1])[None, :] < self.nm_row[rows][:, None]
        return _distinct_errors(lam, pairs, computed, self.tmask[rows])

    def jacobian(self, ev: _Evaluation, sel=None):
        """Exact Jacobians ∂r/∂x (len(sel), T(1 + u), L) at the points of ``ev`` (rows ``sel``)."""
        sel = np.arange(len(ev.rows)) if sel is None else np.asarray(sel, dtype=np.intp)
        rows = ev.rows[sel]
        S, L = sel.size, self.idx.size
        errors = self._check_distinct_rows(ev.lam[sel], ev.pairs[sel], rows)
        per_row = L * self.T * (self.sup_w + 3 * self.n + 2 * self.u) + self.n * self.n
        with np.errstate(all="ignore"):
            chunks = self._chunks(S, per_row)
            parts = [self._jacobian_rows(ev, sel[c]) * self.dp_dx(ev.X[sel[c]], rows[c])[:, :, None] for c in chunks]
            JT = parts[0] if len(parts) == 1 else np.concatenate(parts)
        for r, e in enumerate(errors):
            if e is not None:
                JT[r] = 0.0
        return JT.transpose(0, 2, 1), errors

    def _jacobian_rows(self, ev, sel):
        r"""∂r/∂p for rows ``sel``, parameter-major (S, L, T(1 + u)).

        G_j = (K_j − λ_t M_j) φ_t on the supports; λ_t' = φ_tᵀ G_j (eq. 21);
        φ_t' = Σ_{r≠t} φ_r (−φ_rᵀ G_j)/(λ_r − λ_t) − ½ (φ_tᵀ M_j φ_t) φ_t (complete modal method);
        ψ' = (φ'/s − ψ s'/s) × the alignment sign, s the unit-length scale.
        """
        S, n, L, T, w, u = sel.size, self.n, self.idx.size, self.T, self.sup_w, self.u
        rows = ev.rows[sel]
        lam, Phi, pairs = ev.lam[sel], ev.Phi[sel], ev.pairs[sel]
        lam_p = np.take_along_axis(lam, pairs, axis=1)  # (S, T)
        Phi_p = np.take_along_axis(Phi, pairs[:, None, :], axis=2)  # (S, n, T)
        flat = np.swapaxes(Phi_p, 0, 1).reshape(n, S * T)
        G = (self.K_sup @ flat).reshape(L, w, S, T).transpose(2, 0, 1, 3)  # (S, L, w, T)
        Phi_pw = Phi_p[:, self.sup_idx.ravel(), :].reshape(S, L, w, T)
        if self.M_varies:
            GM = (self.M_sup @ flat).reshape(L, w, S, T).transpose(2, 0, 1, 3)
            G = G - lam_p[:, None, None, :] * GM
            mjj = np.einsum("slwt,slwt->slt", Phi_pw, GM)
        else:
            mjj = None
        d_eig = np.einsum("slwt,slwt->slt", Phi_pw, G) * (self.tmask[rows] / self.rows.lam_e[rows])[:, None, :]  # (S, L, T)
        if not self.has_shape[rows].any():
            out = np.zeros((S, L, T, 1 + u))
            out[..., 0] = d_eig
            return out.reshape(S, L, -1)
        if self.full_support:
            H = np.matmul(np.swapaxes(Phi, 1, 2)[:, None, :, :], G)  # (S, L, n, T)
        else:
            H = np.matmul(np.swapaxes(Phi[:, self.sup_idx.ravel(), :].reshape(S, L, w, n), 2, 3), G)
        inv = 1.0 / (lam_p[:, None, :] - lam[:, :, None])  # (S, n, T)
        ar = np.arange(S)[:, None]
        tt = np.arange(T)[None, :]
        inv[ar, pairs, tt] = 0.0
        coef = H * inv[:, None, :, :]
        if mjj is not None:
            coef[ar, :, pairs, tt] = -0.5 * np.swapaxes(mjj, 1, 2)
        dd = np.matmul(Phi[:, None, self.U, :], coef)  # (S, L, u, T): φ' on the sensors
        Ps, psi, s, flip, mask = (a[sel] for a in ev.shapes)
        f = flip / s  # (S, T)
        ds = np.einsum("sut,slut->slt", Ps, dd) * f[:, None, :]  # s'/s × sign, (S, L, T)
        dpsi = (dd * f[:, None, None, :] - psi[:, None, :, :] * (ds / s[:, None, :])[:, :, None, :]) * mask[:, None]
        return np.concatenate([d_eig[..., None], dpsi.transpose(0, 1, 3, 2)], axis=3).reshape(S, L, -1)


__all__ = ["RowData", "StudyProblem"]
