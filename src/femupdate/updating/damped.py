r"""The damped blocks of the updating engine: measured modes compared with the complex modes of a
damped model (:class:`DampedModesProblem`, block kind ``"damped modes"``), and FRFs compared
with its damped receptances (:class:`DampedFRFProblem`, block kind ``"frf"``).

Both run on a :class:`~femupdate.damping.view.DampedView` — the model's parameters followed by
the damping parameters — inside a :class:`~femupdate.updating.combined.CombinedProblem`, so that
the solver, the diagnostics, multi-start and the result records are those of every update.

**Damped modes.**  Per test mode k, paired with model mode j (the one pairing rule of
:func:`femupdate.correlation.pair`, MAC of complex shapes
:math:`|\psi^H\varphi|^2/(\psi^H\psi\,\varphi^H\varphi)`), the residuals are

.. math::  r_f = w_f\,\frac{|\lambda_j|^2 - \omega_k^2}{\omega_k^2}, \qquad
           r_\zeta = w_\zeta\,(\zeta_j - \zeta_k), \qquad
           r_\psi = w_\psi\,(g\,\varphi_{j,S} - \hat\psi_k), \quad
           g = \frac{a}{\|\varphi_{j,S}\|\,|a|}, \quad a = \varphi_{j,S}^H\hat\psi_k

with :math:`|\lambda|` the undamped natural frequency (rad/s) of the complex eigenvalue λ,
:math:`\zeta = -\operatorname{Re}\lambda/|\lambda|`, :math:`\hat\psi_k` the test shape
(complex or real) scaled to unit length over its measured dofs S, and the model shape scaled to
unit length and turned by the phase that aligns it best with the test shape (g: the unit
complex factor of least :math:`\|g\varphi - \hat\psi\|` among those of modulus
:math:`1/\|\varphi\|`); :math:`r_\psi` enters as its real parts then its imaginary parts.
For real shapes this is the undamped residual of ``--shape-scaling unit`` (:func:`femupdate.rules.shape_residuals`:
:math:`\pm\varphi/\|\varphi\| - \hat\psi`), and a proportionally damped model's complex
shape is a complex multiple of its real one, so the residuals are those of the undamped update
(their imaginary parts zero).  The frequency residual is the relative eigenvalue error
of the undamped modal residual (:mod:`femupdate.rules`): for a proportionally damped model
:math:`|\lambda_j| = \omega_j` and it is the same residual.  Weights: 1 over the stated or
identified standard deviations (``std_eigenvalue`` relative of ω², ``std_damping_ratio``
absolute, ``std_shape`` of the unit shape entries), else 1.

The Jacobian is exact: :math:`\partial|\lambda|^2 = 2\operatorname{Re}(\bar\lambda\,
\partial\lambda)`, :math:`\partial\zeta` from :class:`~femupdate.damping.ComplexSensitivities`,
and :math:`\partial r_\psi = \partial g\,\varphi + g\,\partial\varphi` with
:math:`\partial g = \partial a/(\|\varphi\||a|) - g\,\partial\|\varphi\|/\|\varphi\|
- g\,\partial|a|/|a|`, :math:`\partial a = \partial\varphi^H\hat\psi`,
:math:`\partial\|\varphi\| = \operatorname{Re}(\varphi^H\partial\varphi)/\|\varphi\|`,
:math:`\partial|a| = \operatorname{Re}(\bar a\,\partial a)/|a|`, from the exact eigenvector
derivatives (:func:`~femupdate.damping.complex_sensitivities`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._docs import X as X_DOC, shared_docs
from .._errors import InputError, NumericalError
from ..correlation import pair
from ..damping.complex_modes import DENSE_LIMIT, ComplexModes, complex_modes
from ..damping.frf import damped_response
from ..damping.sensitivity import complex_sensitivities
from ..damping.view import DampedView
from ..frf import residuals as R
from ..sensitivity.subspace import buffered_modes
from ..testdata import FRFData, TestData, check_std_damping_ratio
from .parametrisation import Parametrisation

#: the keys of ``measurement_std`` a damped modes block reads
DAMPED_STD = ("eigenvalue", "damping_ratio", "shape")


def _weights(values: list, given, what: str, T: int) -> tuple[np.ndarray, str]:
    """(weights, source) of one kind of residual: 1 / the caller's std, else 1 / the data's where
    every mode that needs it states it, else 1."""
    if given is not None:
        s = np.broadcast_to(np.asarray(given, float), (T,)) if np.ndim(given) == 0 else np.asarray(given, float)
        if s.shape != (T,) or not np.all(np.isfinite(s) & (s > 0)):
            raise InputError(f"measurement_std[{what!r}]: give one positive value or one per test mode ({T})")
        return 1.0 / s, "given"
    needed = [v for v in values if v is not False]
    if needed and all(v is not None for v in needed):
        return np.array([1.0 / v if v not in (None, False) else 1.0 for v in values]), "data"
    return np.ones(T), "partial" if any(v is not None for v in needed) else ""


_KIND_WORDS = {"eigenvalue": "frequencies", "damping_ratio": "damping ratios", "shape": "shapes"}
_KIND_OPTIONS = {"eigenvalue": "--std-eigenvalue", "damping_ratio": "--std-damping-ratio", "shape": "--std-shape"}


def _kinds(keys) -> str:
    return " and ".join(_KIND_WORDS[k] for k in keys)


def _options(keys) -> str:
    return ", ".join(_KIND_OPTIONS[k] for k in keys)


class DampedModesProblem(Parametrisation):
    """Measured modes (frequencies, damping ratios, complex or real shapes) against the complex
    modes of a damped model; residuals and exact Jacobian as the module says.

    Parameters
    ----------
    view : DampedView
        The damped model as the engine sees it.
    data : TestData
        Measured modes; ``damping_ratio`` and complex shapes where identified.
    names : sequence of str
        The updated parameters (model's and damping's).
    p_base : array_like, shape ``(n_parameters,)``
        The full parameter vector at the start.
    parametrisation : {"relative", "log", "absolute"}
    rule : str, default ``"auto"``
        The pairing rule (:func:`femupdate.correlation.pair`).
    min_mac : float, default 0.5
    std : mapping, optional
        ``{"eigenvalue", "damping_ratio", "shape"}``: one value or one per test mode; a key not
        given is taken from the data where every mode states it.
    use_shapes : bool, default True
    n_modes : int, optional
        Model modes paired among (default ``max(2T, T + 6)``, at most the dofs).

    Attributes
    ----------
    n_residuals : int
    stated : dict of str to str
        The kinds of residual divided by stated deviations, {kind: "given" | "data"}.
    sigma : True or None
        True when every residual is divided by a stated deviation.
    notes : list of str
    """

    def __init__(self, view: DampedView, data: TestData, names: Sequence[str], p_base, parametrisation: str = "relative",
                 rule: str = "auto", min_mac: float = 0.5, std: Mapping | None = None, use_shapes: bool = True,
                 n_modes: int | None = None):
        super().__init__(view, names, parametrisation, p_base)
        if not data.modes:
            raise InputError("updating a damped model from modes needs measured modes")
        self.model = view
        self.dm = view.damped
        self.data = data
        self.rule, self.min_mac = rule, float(min_mac)
        modes = data.modes
        T = len(modes)
        self.lam_e = np.asarray(data.eigenvalues, float)
        if np.any(self.lam_e <= 0):
            raise InputError("test modes at 0 Hz (rigid-body modes) cannot be updating targets")
        self.zeta_e = np.array([math.nan if m.damping_ratio is None else m.damping_ratio for m in modes])
        self.pptr, pos, psi = [0], [], []
        for k, m in enumerate(modes):
            if use_shapes and m.has_shape and len(m.dofs) >= 2:
                v = np.asarray(m.shape, complex)
                nv = np.linalg.norm(v)
                if not nv > 0:
                    raise InputError(f"test mode {k + 1}: its shape is zero")
                pos.extend(view.dof_index(m.dofs, f"test mode {k + 1} shape").tolist())
                psi.extend((v / nv).tolist())
            self.pptr.append(len(pos))
        self.pos, self.psi = np.array(pos, np.int64), np.array(psi, complex)
        self.shaped = np.diff(self.pptr) > 0
        self.has_zeta = np.isfinite(self.zeta_e)
        std = dict(std or {})
        unknown = sorted(set(std) - set(DAMPED_STD))
        if unknown:
            raise InputError(f"measurement_std: a damped modes block takes {', '.join(DAMPED_STD)}, not {unknown[0]!r}")
        wf, sf = _weights([m.std_eigenvalue for m in modes], std.get("eigenvalue"), "eigenvalue", T)
        wz, sz = _weights([m.std_damping_ratio if h else False for m, h in zip(modes, self.has_zeta)],
                          std.get("damping_ratio"), "damping_ratio", T)
        if sz == "given":
            check_std_damping_ratio(float(np.max(1.0 / wz)), "measurement_std['damping_ratio']")
        ws, ss = _weights([m.std_shape if s else False for m, s in zip(modes, self.shaped)], std.get("shape"), "shape", T)
        self.w_f, self.w_z, self.w_s = wf, wz, ws
        self.notes: list[str] = [f"the test data state a standard deviation of the {what} for some modes but not all: "
                                 f"not used (the {what} residuals are weighted 1); state it for every mode, or give "
                                 f"measurement_std[{key!r}]" for key, what, src in
                                 (("eigenvalue", "frequency", sf), ("damping_ratio", "damping ratio", sz),
                                  ("shape", "shape", ss)) if src == "partial"]
        sf, sz, ss = ("" if v == "partial" else v for v in (sf, sz, ss))
        used = {"eigenvalue": sf, "damping_ratio": sz if self.has_zeta.any() else "-",
                "shape": ss if self.shaped.any() else "-"}
        self.stated = {k: v for k, v in used.items() if v not in ("", "-")}
        self.sigma = True if all(v for v in used.values()) else None
        unstated = [k for k, v in used.items() if v == ""]
        if self.stated and unstated:  # one noise scale is estimated for the whole block
            self.notes.append(
                f"standard deviations stated for the {_kinds(self.stated)} of the damped modes but not for the "
                f"{_kinds(unstated)}: the block's noise is estimated as one scale on all its residuals as weighted, so "
                "the stated deviations act as relative weights, multiplied by that scale, and the standard deviations "
                f"do not rest on them; state them for the {_kinds(unstated)} too ({_options(unstated)}, or in the test data)")
        ns = np.diff(self.pptr)
        self.n_residuals = int(T + self.has_zeta.sum() + 2 * ns.sum())
        self.n_independent = int(T + self.has_zeta.sum() + 2 * np.maximum(ns - 1, 0).sum())
        self.n_modes = int(min(view.n_dofs, n_modes or buffered_modes(T)))
        big = [k + 1 for k in np.flatnonzero(self.zeta_e > 0.2)]
        if big:
            self.notes.append(f"test mode(s) {', '.join(map(str, big))} have damping ratios above 0.2 (20 % of critical): "
                              "damping ratios are fractions; if they were meant in percent, divide them by 100")
        self.pairing_used = ""
        self.nfev = 0
        self._cache: dict = {}

    # ------------------------------------------------------------------ evaluation
    @shared_docs(X=X_DOC)
    def evaluate(self, x) -> tuple[np.ndarray, ComplexModes, list[tuple[int, int, float]]]:
        """Parameters, complex modes and pairs at x (the last point cached).

        {{X}}
        p : numpy.ndarray
        modes : ComplexModes
        pairs : list of (int, int, float)
            ``(test mode, model mode, MAC)``, 0-based; MAC NaN without shape.
        """
        x = np.asarray(x, float)
        key = x.tobytes()
        if key in self._cache:
            return self._cache[key]
        p = self.to_p(x)
        dense = self.dm.n_dofs <= DENSE_LIMIT
        modes = complex_modes(self.dm, n_modes=None if dense else self.n_modes, values=p)
        if modes.n_modes > self.n_modes:
            modes = ComplexModes(modes.eigenvalues[:self.n_modes], modes.shapes[:, :self.n_modes], modes.dofs,
                                 modes.solver, modes.n_rigid, modes.n_overdamped, modes.modal)
        T, nm = self.lam_e.size, modes.n_modes
        MAC = np.zeros((T, nm))
        for k in map(int, np.flatnonzero(self.shaped)):
            MAC[k] = self.mac_row(modes, k)
        pg = pair(MAC, rule=self.rule, min_mac=self.min_mac, shaped=self.shaped,
                  model_eigenvalues=np.abs(modes.eigenvalues) ** 2, test_eigenvalues=self.lam_e, strict=True)
        self.pairing_used = pg.used
        out = (p, modes, [(int(k), int(j), float(m)) for k, j, m in pg.pairs])
        self._cache = {key: out}
        return out

    def mac_row(self, modes: ComplexModes, k: int) -> np.ndarray:
        """MAC of test mode k's (unit) shape with every model mode over its measured dofs."""
        sl = slice(self.pptr[k], self.pptr[k + 1])
        U = modes.shapes[self.pos[sl], :]
        num = np.abs(np.conj(self.psi[sl]) @ U) ** 2
        den = np.sum(np.abs(U) ** 2, axis=0)
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)

    @shared_docs(X=X_DOC)
    def residuals(self, x) -> np.ndarray:
        """The residuals at x: per test mode its frequency, damping-ratio and complex shape
        residuals (see the module).

        {{X}}
        numpy.ndarray, shape ``(n_residuals,)``
        """
        self.nfev += 1
        _, modes, pairs = self.evaluate(x)
        r = np.zeros(self.n_residuals)
        row = 0
        for k, j, _ in pairs:
            lam = modes.eigenvalues[j]
            r[row] = self.w_f[k] * (abs(lam) ** 2 - self.lam_e[k]) / self.lam_e[k]
            row += 1
            if self.has_zeta[k]:
                r[row] = self.w_z[k] * (-lam.real / abs(lam) - self.zeta_e[k])
                row += 1
            if self.shaped[k]:
                sl = slice(self.pptr[k], self.pptr[k + 1])
                u, v = modes.shapes[self.pos[sl], j], self.psi[sl]
                a = np.vdot(u, v)
                e = u * (a / (np.linalg.norm(u) * abs(a))) - v
                n = v.size
                r[row:row + n], r[row + n:row + 2 * n] = self.w_s[k] * e.real, self.w_s[k] * e.imag
                row += 2 * n
        if not np.all(np.isfinite(r)):
            raise NumericalError("non-finite residuals of the damped modes")
        return r

    @shared_docs(X=X_DOC)
    def jacobian(self, x) -> np.ndarray:
        """The exact Jacobian ∂r/∂x (:func:`~femupdate.damping.complex_sensitivities`).

        {{X}}
        numpy.ndarray, shape ``(n_residuals, L)``
        """
        x = np.asarray(x, float)
        p, modes, pairs = self.evaluate(x)
        which = [j for _, j, _ in pairs]
        sub = ComplexModes(modes.eigenvalues[which], modes.shapes[:, which], modes.dofs, modes.solver,
                           modal=modes.modal)
        cs = complex_sensitivities(self.dm, sub, p, self.names, vectors=bool(self.shaped.any()))
        dzeta = cs.d_damping_ratios
        dpdx = self.dp_dx(x)
        J = np.zeros((self.n_residuals, self.idx.size))
        row = 0
        for c, (k, j, _) in enumerate(pairs):
            lam, dl = sub.eigenvalues[c], cs.d_eigenvalues[c]
            J[row] = self.w_f[k] * 2 * (np.conj(lam) * dl).real / self.lam_e[k] * dpdx
            row += 1
            if self.has_zeta[k]:
                J[row] = self.w_z[k] * dzeta[c] * dpdx
                row += 1
            if self.shaped[k]:
                assert cs.d_shapes is not None
                sl = slice(self.pptr[k], self.pptr[k + 1])
                u, v, du = sub.shapes[self.pos[sl], c], self.psi[sl], cs.d_shapes[self.pos[sl], c, :]
                a, nu = np.vdot(u, v), np.linalg.norm(u)
                g = a / (nu * abs(a))
                da = np.conj(du).T @ v
                dn = (np.conj(u) @ du).real / nu
                dabs = (np.conj(a) * da).real / abs(a)
                dg = da / (nu * abs(a)) - a * dn / (nu ** 2 * abs(a)) - a * dabs / (nu * abs(a) ** 2)
                de = (u[:, None] * dg[None, :] + g * du) * dpdx[None, :]
                n = v.size
                J[row:row + n], J[row + n:row + 2 * n] = self.w_s[k] * de.real, self.w_s[k] * de.imag
                row += 2 * n
        return J

    def paired(self, x) -> dict:
        """The correlation part of a result at x (``pairs``, frequencies, ``pairing``) and the
        damping ratios and MPC of the paired model modes."""
        _, modes, pairs = self.evaluate(x)
        macs = [m for _, _, m in pairs]
        low = [k for k, m in enumerate(macs) if np.isfinite(m) and not m >= self.min_mac]
        js = [j for _, j, _ in pairs]
        return dict(pairs=[(k, j, m if np.isfinite(m) else math.nan) for k, j, m in pairs],
                    test_frequencies_hz=self.data.frequencies_hz,
                    model_frequencies_hz=np.array([modes.natural_frequencies_hz[j] for j in js]),
                    pairing={"policy": self.rule, "used": self.pairing_used, "min_mac": self.min_mac, "low_mac": low},
                    model_damping_ratios=[float(modes.damping_ratios[j]) for j in js],
                    model_mpc=[float(modes.mpc[j]) for j in js], complexity=self.complexity(modes, pairs))

    def complexity(self, modes: ComplexModes, pairs) -> dict:
        """MPC and MPD (degrees) of each paired test shape and of its model mode's shape at the
        same measured dofs (:mod:`femupdate.damping.complexity`); None for a mode without a shape."""
        from ..damping.complexity import mean_phase_deviation, modal_phase_collinearity

        out: dict = {"test": {"mpc": [], "mpd_deg": []}, "model": {"mpc": [], "mpd_deg": []}}
        for k, j, _ in pairs:
            sl = slice(self.pptr[k], self.pptr[k + 1])
            for side, v in (("test", self.psi[sl]), ("model", modes.shapes[self.pos[sl], j])):
                shaped = self.shaped[k]
                out[side]["mpc"].append(float(modal_phase_collinearity(v)) if shaped else None)
                out[side]["mpd_deg"].append(float(mean_phase_deviation(v)) if shaped else None)
        return out


class DampedFRFProblem(Parametrisation):
    r"""One FRF set against the damped receptances :math:`x = (K + iD - \omega^2 M + i\omega C)^{-1} f`
    (:func:`~femupdate.damping.frf.damped_response`), residual ``"linear"``, ``"relative"`` or
    ``"log"`` (:mod:`femupdate.frf.residuals`), exact Jacobian.

    Parameters
    ----------
    view : DampedView
    frf : FRFData
    names : sequence of str
    p_base : array_like
    parametrisation : str
    residual : {"linear", "relative", "log"}
    weights : None or array_like
        Broadcastable to ``frf.response``.

    Attributes
    ----------
    kind, omega, xe, S, n_residuals, skipped, weighting
        As :class:`~femupdate.updating.frf.FRFProblem`.
    """

    def __init__(self, view: DampedView, frf: FRFData, names, p_base, parametrisation: str = "relative",
                 residual: str = "linear", weights=None):
        super().__init__(view, names, parametrisation, p_base)
        self.model = view
        self.dm = view.damped
        self.kind = R.check_kind(residual)
        self.frf = frf
        self.S = view.dof_index(frf.dofs, "frf response")
        use = frf.omega > 0
        self.omega = frf.omega[use]
        xe = np.asarray(frf.response[use], complex)
        w = np.broadcast_to(np.asarray(1.0 if weights is None else weights, float), frf.response.shape)[use]
        self.w, self.target = R.prepare(xe, self.kind, w, False)
        self.xe = xe
        self.n_residuals = int(xe.size * (1 if self.kind == "log" else 2))
        self.skipped: list[dict] = []
        self.weighting = "as given"
        self.nfev = 0
        self._cache: dict = {}

    def _evaluate(self, x, derivatives: bool):
        key = (np.asarray(x, float).tobytes(), derivatives)
        if key not in self._cache:
            p = self.to_p(np.asarray(x, float))
            out = damped_response(self.dm, self.omega, dict(self.frf.force), self.frf.dofs, p,
                                  self.names if derivatives else None)
            self._cache = {key: out}
        return self._cache[key]

    @shared_docs(X=X_DOC)
    def responses(self, x) -> np.ndarray:
        """The model's responses at the measured dofs, ``(n_l, n_s)`` complex.

        {{X}}
        numpy.ndarray
        """
        return self._evaluate(x, False)[0]

    @shared_docs(X=X_DOC)
    def residuals(self, x) -> np.ndarray:
        """The residuals at x (line-major; real parts of every line, then imaginary parts).

        {{X}}
        numpy.ndarray, shape ``(n_residuals,)``
        """
        self.nfev += 1
        r = R.values(self.responses(x), self.target, self.w, self.kind).ravel()
        if not np.all(np.isfinite(r)):
            raise NumericalError("non-finite damped FRF residuals")
        return r

    @shared_docs(X=X_DOC)
    def jacobian(self, x) -> np.ndarray:
        """The exact Jacobian: ∂x_S/∂p_j = −Y_Sᵀ ∂Z_j x (:func:`~femupdate.damping.frf.damped_response`).

        {{X}}
        numpy.ndarray, shape ``(n_residuals, L)``
        """
        xa, dx = self._evaluate(x, True)
        J = R.jacobian(xa, dx, self.w, self.kind)
        return J.reshape(-1, self.idx.size) * self.dp_dx(np.asarray(x, float))[None, :]


__all__ = ["DampedModesProblem", "DampedFRFProblem", "DAMPED_STD"]
