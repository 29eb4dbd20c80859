r"""Conditioning of FRF data and the choice of spectral lines.

**Condition study (paper Figure 4).**  With every dof measured, each line ω gives the linear
equations of eq. 24-28, :math:`X\,p = f + M\omega^2 x` with the block
:math:`X_\omega = [(K_j - \omega^2 M_j)\,x(\omega)]_j` (eq. 25; complex responses give real and
imaginary rows).  :func:`condition_study` stacks ``n_lines`` lines
:math:`\omega_k = \omega_1 + (k-1)\Delta` and returns cond(X) over a grid of lowest frequency
:math:`\omega_1` and spacing Δ — all combinations solved and decomposed at once (one stacked
solve, one batched SVD).  The paper's Figure 4 is the diagonal :math:`\omega_1 = \Delta`.

**Frequency selection** (He 1993; Ren & Beards 1993, both cited by the paper).
:func:`select_frequencies` picks ``n_lines`` of the candidate lines that make the stacked
matrix best conditioned while keeping a margin from the model's resonances, where FRF data are
sensitive to small frequency errors and first-order sensitivities are least accurate:

* ``kind="direct"``: the blocks :math:`X_\omega` of complete data (eq. 28);
* ``kind="sensitivity"``: for incomplete data, the normalised sensitivity rows
  :math:`p_j\,\partial x_R/\partial p_j\,/\,\|x_R(\omega)\|` of the measured responses
  (eq. 31 with Brandon's eq. 32), each line scaled to unit response so that a line does not
  count for more merely because its response is large.

Up to ``exhaustive_limit`` subsets are all evaluated (batched SVDs: the exact optimum).  Beyond,
the search is greedy (D-optimal: each step adds the line that most increases
:math:`\log\det(A^TA)`), then exchange passes (Fedorov) swap chosen and unchosen lines while the
condition number falls, from the greedy set and from random sets; every trial of a pass is
evaluated in one batched SVD.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .._docs import FORCE, FRF_LINES, shared_docs
from .._errors import InputError
from ..options import SELECTION_EQUATIONS, SelectionOptions, gather
from ..serialise import RunContext, Serialisable
from .damping import as_damping
from .lines import LineSystems, check_omega, derivative_stack, force_vector
from .resonance import resonances
from .sensitivity import receptance_sensitivity

log = logging.getLogger(__name__)

KINDS = SELECTION_EQUATIONS  #: the equations judged (SelectionOptions.equations)


def _unknowns(model, unknowns) -> list[int]:
    idx = [int(j) for j in model.free] if unknowns is None else [model.parameter_index(n) for n in unknowns]
    if not idx:
        raise InputError("no unknown parameters: every parameter is fixed")
    return idx


def _real_rows(A: np.ndarray) -> np.ndarray:
    """Complex row blocks ``(..., rows, L)`` as real ones with the imaginary rows appended."""
    return np.concatenate([A.real, A.imag], axis=-2) if np.iscomplexobj(A) else A


@shared_docs(FRF_LINES=FRF_LINES, FORCE=FORCE)
def direct_blocks(model, omega, force: Mapping, values=None, unknowns=None, damping=None) -> np.ndarray:
    r"""The eq. 25 block :math:`X_\omega = [(K_j - \omega^2 M_j)\,x(\omega)]_j` of every line,
    ``(n_lines, rows, L)`` with ``x`` the simulated complete response to ``force`` (real rows;
    complex responses give real and imaginary rows).  An undamped line exactly on a resonance
    gives a block of ``inf``.

    Parameters
    ----------
    {{FRF_LINES}}
    {{FORCE}}
    values : None, mapping of str to float, or array_like, optional
        Parameter values of the simulated response (default nominal).
    unknowns : sequence of str, optional
        Parameters of the columns (default: the free ones).
    damping : Damping or mapping, optional
        Default undamped.

    Returns
    -------
    numpy.ndarray, shape ``(n_lines, rows, L)``
        rows = n_dofs for real responses, 2 n_dofs (real, then imaginary) for complex ones.

    Raises
    ------
    InputError
        No unknown parameter; bad frequencies; a malformed force; and as :meth:`Model.resolve`.
    """
    w = check_omega(omega)
    damping = as_damping(damping)
    p = model.resolve(values)
    idx = _unknowns(model, unknowns)
    f = force_vector(model, force)
    sys_ = LineSystems(model, p, w, damping)
    X = sys_.solve(f, on_singular="inf")  # (n_l, n)
    Ks, Ms = derivative_stack(model, idx, p)
    L, n = len(idx), model.n_dofs
    finite = np.all(np.isfinite(X), axis=1)
    Xf = np.where(finite[:, None], X, 0.0)
    KX = (Ks @ Xf.T).reshape(L, n, -1)  # (L, n, n_l)
    MX = (Ms @ Xf.T).reshape(L, n, -1)
    blocks = sys_.cK[None, None, :] * KX + sys_.cM[None, None, :] * MX
    blocks = np.transpose(blocks, (2, 1, 0))  # (n_l, n, L)
    blocks = _real_rows(blocks)
    blocks[~finite] = np.inf
    return blocks


def _cond(stack: np.ndarray, scaled: bool) -> np.ndarray:
    """Condition numbers of a stack of tall matrices ``(G, m, L)`` (inf where not finite or rank deficient)."""
    ok = np.all(np.isfinite(stack), axis=(-2, -1))
    S = np.where(ok[:, None, None], stack, 0.0)
    if scaled:
        nrm = np.linalg.norm(S, axis=-2, keepdims=True)
        S = S / np.where(nrm > 0, nrm, 1.0)
    s = np.linalg.svd(S, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(s[:, -1] > 0, s[:, 0] / s[:, -1], np.inf)
    return np.where(ok, c, np.inf)


@dataclass(frozen=True, eq=False)
class ConditionStudy:
    """cond(X) (eq. 28) for ``n_lines`` lines ``start + k spacing``, k = 0 .. n_lines-1.

    ``condition`` and ``condition_scaled`` (columns of X scaled to unit length) have shape
    ``(len(starts), len(spacings))``.  The paper's Figure 4 reading, lowest line = spacing, is what
    :func:`condition_study` gives with ``starts=None``: then ``starts`` is ``[nan]`` and the
    arrays have one row.

    Parameters
    ----------
    starts : numpy.ndarray, shape ``(n_starts,)``
        Lowest lines ω_1, rad/s (``[nan]`` when the lowest line equals the spacing).
    spacings : numpy.ndarray, shape ``(n_spacings,)``
        Spacings Δ, rad/s.
    n_lines : int
        Lines per combination.
    force : dict of str to float or complex
        The simulated test's force, N per dof.
    unknowns : tuple of str
        Parameters of the columns of X.
    condition : numpy.ndarray, shape ``(n_starts, n_spacings)``
        cond(X) (2-norm; inf where X is rank deficient or a line falls on an undamped resonance).
    condition_scaled : numpy.ndarray, shape ``(n_starts, n_spacings)``
        The same with the columns of X scaled to unit length.
    """

    starts: np.ndarray
    spacings: np.ndarray
    n_lines: int
    force: dict
    unknowns: tuple[str, ...]
    condition: np.ndarray
    condition_scaled: np.ndarray


def condition_study(model, force: Mapping, spacings, starts=None, n_lines: int = 5, values=None, unknowns=None,
                    damping=None) -> ConditionStudy:
    """cond(X) of eq. 28 against the lowest frequency and the spacing of ``n_lines`` lines.

    Parameters
    ----------
    model : Model
        The parametrised model.
    force : mapping of str to float or complex
        Force amplitude (N) per dof of the simulated test (complete response at every model dof).
    spacings : array_like, shape ``(n_spacings,)``
        Line spacings Δ, rad/s, positive.
    starts : array_like, shape ``(n_starts,)``, optional
        Lowest lines ω_1, rad/s.  ``None``: the lowest line equals the spacing (the paper's
        Figure 4); the result then has one row, ``condition`` of shape ``(1, len(spacings))``, and
        its ``starts`` is ``[nan]``.
    n_lines : int, default 5
        Lines per combination (the paper: 5).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of the simulated response (default nominal).
    unknowns : sequence of str, optional
        Parameters of the columns of X (default: the free ones).
    damping : Damping or mapping, optional
        Default undamped.

    Returns
    -------
    ConditionStudy

    Raises
    ------
    InputError
        Spacings not positive; ``n_lines`` below 1; frequencies not finite or negative; no unknown
        parameter or an unknown name; a malformed force; and as :meth:`Model.resolve`.
    """
    sp_ = check_omega(spacings, "spacings")
    if np.any(sp_ <= 0):
        raise InputError("spacings must be positive")
    n_lines = int(n_lines)
    if n_lines < 1:
        raise InputError("n_lines must be at least 1")
    idx = _unknowns(model, unknowns)
    k = np.arange(n_lines)
    if starts is None:
        omega = sp_[None, :, None] * (1 + k)[None, None, :]  # (1, n_d, n_lines)
    else:
        st = check_omega(starts, "starts")
        omega = st[:, None, None] + sp_[None, :, None] * k[None, None, :]
    shape = omega.shape[:2]
    flat = omega.reshape(-1)
    uniq, inv = np.unique(flat, return_inverse=True)
    blocks = direct_blocks(model, uniq, force, values, [model.parameter_names[j] for j in idx], damping)
    rows = blocks.shape[1]
    A = blocks[inv].reshape(shape[0] * shape[1], n_lines * rows, len(idx))
    cond = _cond(A, scaled=False).reshape(shape)
    cond_s = _cond(A, scaled=True).reshape(shape)
    return ConditionStudy(st if starts is not None else np.array([np.nan]), sp_, n_lines,
                          {str(d): v for d, v in force.items()}, tuple(model.parameter_names[j] for j in idx),
                          cond, cond_s)


@dataclass(frozen=True, eq=False)
class Selection(Serialisable):
    """Chosen spectral lines (:func:`select_frequencies`); a result of kind ``frf-select``
    (``femupdate frf-select``): :meth:`~femupdate.serialise.Serialisable.to_json` gives the
    command's JSON.

    Attributes
    ----------
    omega : ndarray, shape ``(n_lines,)``
        The chosen lines (rad/s), ascending.
    index : ndarray of int, shape ``(n_lines,)``
        Their 0-based positions among ``candidates``.
    condition_number : float
        cond of the stacked matrix of the chosen lines (columns scaled when ``scaled``).
    equations : {"direct", "sensitivity"}
        The equations judged (:attr:`SelectionOptions.equations <femupdate.options.SelectionOptions.equations>`).
    candidates : ndarray, shape ``(n_candidates,)``
        The candidate lines, rad/s, as given (empty when read back from JSON).
    excluded : list of dict
        Candidates left out and why ({line, omega_rad_s, reason}).
    uniform : dict
        The same number of lines evenly spread over the allowed candidates, for comparison
        ({omega_rad_s, condition_number}).
    history : list
        The optimum (exhaustive), or per start the condition number after each exchange pass.
    method : str
        ``"exhaustive"`` or ``"greedy + exchange (...)"`` (empty when read back from JSON).
    context : RunContext, optional
        The model the lines were chosen for (its name goes into the JSON).
    """

    omega: np.ndarray
    index: np.ndarray
    condition_number: float
    equations: str
    candidates: np.ndarray
    excluded: list = field(default_factory=list)
    uniform: dict = field(default_factory=dict)
    history: list = field(default_factory=list)
    method: str = ""
    context: RunContext | None = field(default=None, compare=False, repr=False)

    kind: ClassVar[str] = "frf-select"

    def payload(self) -> dict:
        from .record import selection_fields

        return selection_fields(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import selection_from

        return selection_from(obj)

    def records(self) -> list[dict]:
        """One record per chosen line: ``line`` (1-based among the candidates), ``omega_rad_s``."""
        return [{"line": int(i) + 1, "omega_rad_s": float(w)} for i, w in zip(self.index, self.omega)]


def _logdet(stack: np.ndarray) -> np.ndarray:
    s = np.linalg.svd(stack, compute_uv=False)
    return np.sum(np.log(s**2 + 1e-300), axis=-1)


def select_frequencies(model, candidates, n_lines: int, force: Mapping, options: SelectionOptions | None = None, *,
                       response: Sequence[str] | None = None, unknowns: Sequence[str] | None = None, values=None,
                       damping=None, **shorthand) -> Selection:
    """Choose ``n_lines`` candidate lines that make the updating equations best conditioned.

    Parameters
    ----------
    model : Model
        The parametrised model.
    candidates : array_like, shape ``(n_candidates,)``
        Candidate lines, rad/s (e.g. the measured frequency axis), each once.
    n_lines : int
        Number of lines to choose.
    force : mapping of str to float or complex
        Force amplitude (N) per loaded dof of the test.
    options : SelectionOptions, optional
        The equations judged (``"direct"``: complete data, eq. 28; ``"sensitivity"``: data
        measured at ``response``, eqs. 31-32), the margin from resonances and the search
        (:class:`~femupdate.options.SelectionOptions`; its fields are also accepted as keywords:
        ``kind="sensitivity"``, ``margin=0.02``, ...).
    response : sequence of str, optional
        Measured dofs (``"sensitivity"``; default every dof).
    unknowns : sequence of str, optional
        Parameters to identify (default every parameter not ``fixed``).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of the model (default nominal); the resonances kept away from are
        those of the model at these values.
    damping : Damping or mapping, optional
        Default undamped.
    **shorthand
        Fields of :class:`~femupdate.options.SelectionOptions` as keywords.

    Returns
    -------
    Selection

    Raises
    ------
    InputError
        An unknown ``kind``; candidates not finite, negative or repeated; fewer admissible
        candidates than lines, or too few equations for the unknowns; no unknown parameter or an
        unknown name; a malformed force.
    TypeError
        A keyword :class:`~femupdate.options.SelectionOptions` does not have.
    """
    o = gather("select_frequencies", shorthand, options=(SelectionOptions, options))["options"]
    kind, margin, scaled = o.equations, o.margin, o.scaled
    cand = check_omega(candidates, "candidates")
    if np.unique(cand).size != cand.size:
        raise InputError("candidates: the same line is listed twice")
    n_lines = int(n_lines)
    idx = _unknowns(model, unknowns)
    names = [model.parameter_names[j] for j in idx]
    p = model.resolve(values)
    res = resonances(model, cand, p) if margin > 0 else None  # no margin: nothing to exclude
    near = res.near(margin) if res is not None else np.array([], dtype=np.intp)
    excluded = [{"line": int(i) + 1, "omega_rad_s": float(cand[i]),
                 "reason": f"within {margin:g} of a resonance ({res.describe([i])})"}
                for i in near] if res is not None else []  # near is empty without resonances
    if kind == "direct":
        blocks = direct_blocks(model, cand, force, p, names, damping)
    else:
        f = force_vector(model, force)
        exc = [model.dofs[k] for k in np.flatnonzero(f)]
        sens = receptance_sensitivity(model, cand, response, exc, names, p, damping, resonance_check=False)
        x, dx = sens.for_force({d: f[model.dofs.index(d)] for d in exc})
        scale = np.linalg.norm(x, axis=1)
        blocks = _real_rows(dx * p[idx][None, None, :] / np.where(scale > 0, scale, 1.0)[:, None, None])
    bad = np.flatnonzero(~np.all(np.isfinite(blocks), axis=(1, 2)))
    excluded += [{"line": int(i) + 1, "omega_rad_s": float(cand[i]), "reason": "singular (exactly on a resonance)"}
                 for i in bad if i not in near]
    allowed = np.setdiff1d(np.arange(cand.size), np.concatenate([near, bad]))
    if allowed.size < n_lines:
        raise InputError(f"only {allowed.size} of {cand.size} candidate lines keep a margin of {margin:g} from the "
                         f"model's resonances; {n_lines} were asked for (give more candidates or a smaller margin)")
    rows = blocks.shape[1]
    L = len(idx)
    if n_lines * rows < L:
        raise InputError(f"{n_lines} lines give {n_lines * rows} equations for {L} unknowns: choose at least "
                         f"{-(-L // rows)} lines")
    B = blocks
    if scaled:  # scale the columns once over all admissible candidates: unit-free, same for every subset
        nrm = np.sqrt(np.sum(B[allowed] ** 2, axis=(0, 1)))
        B = B / np.where(nrm > 0, nrm, 1.0)
    n_comb = math.comb(allowed.size, n_lines)
    if n_comb <= o.exhaustive_limit:  # every subset, in batched SVDs
        best, chosen = np.inf, []
        combos = itertools.combinations(allowed.tolist(), n_lines)
        while True:
            chunk = np.array(list(itertools.islice(combos, 20000)))
            if chunk.size == 0:
                break
            c = _cond(B[chunk].reshape(chunk.shape[0], -1, L), scaled)
            k = int(np.argmin(c))
            if c[k] < best:
                best, chosen = float(c[k]), chunk[k].tolist()
        history, how = [best], "exhaustive"
    else:
        rng = np.random.default_rng(o.seed)
        inits = [_greedy(B, allowed, n_lines, L)] + [rng.choice(allowed, n_lines, replace=False).tolist()
                                                      for _ in range(o.restarts)]
        best, chosen, history = np.inf, [], []
        for init in inits:
            c, sub, hist = _exchange(B, allowed, list(map(int, init)), L, scaled, o.max_passes)
            history.append(hist)
            if c < best:
                best, chosen = c, sub
        how = f"greedy + exchange ({o.restarts} random restarts)"
    chosen_arr = np.sort(np.array(chosen))
    even = allowed[np.unique(np.round(np.linspace(0, allowed.size - 1, n_lines)).astype(int))]
    uniform = {"omega_rad_s": cand[even], "condition_number": float(_cond(B[even].reshape(1, -1, L), scaled)[0])}
    return Selection(cand[chosen_arr], chosen_arr, float(best), kind, cand, excluded, uniform, history, how,
                     context=RunContext(model=model))


def _greedy(B, allowed, n_lines, L) -> list[int]:
    """D-optimal forward selection: each step adds the line that most increases log det(AᵀA)."""
    chosen: list[int] = []
    for _ in range(n_lines):
        rest = np.setdiff1d(allowed, chosen)
        trial = np.stack([B[chosen + [c]].reshape(-1, L) for c in rest])
        chosen.append(int(rest[np.argmax(_logdet(trial))]))
    return chosen


def _exchange(B, allowed, chosen, L, scaled, max_passes):
    """Fedorov exchange: swap one chosen line for the unchosen one that lowers cond most, while
    it falls; every candidate swap of one position in one batched SVD."""
    n_lines = len(chosen)
    best = float(_cond(B[chosen].reshape(1, -1, L), scaled)[0])
    history = [best]
    for _ in range(max_passes):
        improved = False
        for pos in range(n_lines):
            rest = np.setdiff1d(allowed, chosen)
            if rest.size == 0:
                break
            trials = np.repeat(np.array(chosen)[None, :], rest.size, axis=0)
            trials[:, pos] = rest
            c = _cond(B[trials].reshape(rest.size, -1, L), scaled)
            k = int(np.argmin(c))
            if c[k] < best * (1 - 1e-12):
                best, chosen[pos], improved = float(c[k]), int(rest[k]), True
        history.append(best)
        if not improved:
            break
    return best, chosen, history
