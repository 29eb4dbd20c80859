r"""The sparse factorisation layer: what the solves of one model share from one evaluation to the next.

Every sparse solve of the package goes through :func:`factorize` (one matrix) or a
:class:`SparseWorkspace` (the same pattern, new values); every factorisation they return is a
:class:`Factor` (``solve``, ``nearly_singular``, ``name``).  Three backends (:func:`backend`,
chosen by :attr:`femupdate.settings.Settings.factorisation` or passed explicitly):

* **CHOLMOD** (scikit-sparse, the optional extra ``femupdate[cholmod]``): supernodal Cholesky of
  the symmetric positive definite matrices — K, K − σM below the lowest eigenvalue, the omitted
  block K_oo of a reduction — with a fill-reducing ordering (AMD or METIS) and about half of
  SuperLU's fill (a 102,600-dof frame tower: 44 M entries against 73 M);
* **MKL PARDISO** (:mod:`.pardiso`; the mkl package, which ``pip install femupdate`` brings on
  x86_64 Linux without system headers): the same supernodal Cholesky of the same matrices, with
  METIS's nested dissection and MKL's kernels, its analysis kept and refactorised as CHOLMOD's —
  the backend of ``auto`` where scikit-sparse is missing;
* **SuperLU** (SciPy) for everything Cholesky cannot take (indefinite or complex symmetric
  matrices: the dynamic stiffness K − ω²M at a frequency line, Nelson's bordered matrix), and for
  everything when neither CHOLMOD nor PARDISO is installed.

Updating a large model solves :math:`K(p)\phi = \lambda M(p)\phi` at many parameter values p,
start after start and iteration after iteration.  The values change; the sparsity pattern does
not: :class:`~femupdate.Model` assembles K(p) and M(p) onto the union pattern of its matrices
(:attr:`Model._pattern`) whatever p.  A :class:`SparseWorkspace` keeps what depends on that
pattern only, found once per model:

* **the route and the ordering** (:mod:`.routes`: :class:`~.routes.BandRoute`,
  :class:`~.routes.CholmodRoute`, :class:`~.routes.PardisoRoute`, :class:`~.routes.SuperLURoute`, each owning its own state,
  taken once by :func:`~.routes.choose_route`).  The first factorisation of K − σM is made by the backend
  (CHOLMOD and PARDISO analyse the pattern once — its ordering and symbolic factor — and every
  later factorisation reuses that analysis; SuperLU's fill-reducing ordering is kept and applied to the
  pattern, since SciPy's SuperLU cannot keep a symbolic factorisation but takes a pre-permuted
  matrix in its natural order).  Its fill is then compared with a *band* Cholesky factor in a
  bandwidth-reducing ordering (reverse Cuthill–McKee or the given order, whichever is narrower)
  by their operation counts (:func:`band_wins`): the band factor (LAPACK ``pbtrf``) runs on
  dense blocked kernels, about eight times faster per operation, and wins for slender or
  moderate models — a frame tower of 102,600 dofs factorises in 1.1 s by the band against
  4.0 s by CHOLMOD and 10 s by SuperLU (one BLAS thread).  The choice depends on the pattern
  alone (not on a timing), so runs are reproducible.
* **the scatter maps.**  Where each stored entry of K and of M lands in the factorised storage
  (the band, or the compressed columns): K − σM is one ``zeros`` and two indexed stores.

The band factor *is* the symbolic factorisation of the band route: its structure is fixed by
the ordering, and reused as such.  Its solves with many right-hand sides (the sensitivities'
series: every mode's parameters at once) go by dense blocks of the bandwidth, matrix-matrix
kernels, instead of LAPACK's column-by-column ``pbtrs`` (36 columns on the 2,304-dof building:
about 1.4 times faster).

Safety: a workspace belongs to one model (a weak-keyed cache, :func:`workspace_of`) and is used
only for matrices whose compressed-row pattern is exactly the one it was built for (checked at
every call, :meth:`SparseWorkspace.matches`); anything else is factorised afresh.  The values
cannot change the pattern (assembly is onto the union pattern; a value that makes an entry zero
leaves an explicit zero), so there is no stale reuse.  The factorisations are exact (backward
stable LU or Cholesky): every route gives the same eigenpairs to round-off.
"""

from __future__ import annotations

import weakref

import scipy.sparse as sp

from .._threads import blas_phase
from .band import BLOCKED_MIN_BANDWIDTH, BLOCKED_MIN_COLUMNS, BandCholesky
from .factors import (PIVOT_THRESHOLD, CholmodFactor, Factor, NotPositiveDefinite, OrderedLU, PardisoFactor,
                      SuperLUFactor, backend, cholmod_installed, factorize, nearly_singular, nearly_singular_pivots,
                      pardiso_installed, superlu)
from .routes import (BAND_EFFICIENCY, LARGE_CHOLMOD, LARGE_FACTOR_OPS, MAX_BAND_ENTRIES, Pattern, Route, band_wins,
                     choose_route)

__all__ = ["SparseWorkspace", "Factor", "BandCholesky", "OrderedLU", "SuperLUFactor", "CholmodFactor", "PardisoFactor",
           "NotPositiveDefinite", "workspace_of", "factorize", "superlu", "backend", "cholmod_installed",
           "pardiso_installed", "band_wins",
           "factor_name", "nearly_singular", "nearly_singular_pivots", "PIVOT_THRESHOLD", "MAX_BAND_ENTRIES",
           "BAND_EFFICIENCY", "LARGE_FACTOR_OPS", "LARGE_CHOLMOD", "BLOCKED_MIN_COLUMNS", "BLOCKED_MIN_BANDWIDTH"]


class SparseWorkspace:
    """The reusable part of the factorisations of K − σM for one sparsity pattern.

    Parameters
    ----------
    K, M : scipy.sparse.csr_array, shape ``(n, n)``
        Matrices with the pattern of every later call (their values are not kept).
    prefer : {None, "band", "sparse"}
        The route: chosen by :func:`band_wins` (None), or imposed — the band (if its storage is
        within :data:`MAX_BAND_ENTRIES`) or the backend's sparse factor — for comparisons.
    backend : {"auto", "cholmod", "pardiso", "superlu"}, optional
        The sparse backend, as :func:`backend` takes it (default: the process's setting,
        :attr:`femupdate.settings.Settings.factorisation`); resolved here, once.

    Attributes
    ----------
    backend : str
        ``"cholmod"``, ``"pardiso"`` or ``"superlu"``.
    n_factorisations : int
        Factorisations made through the workspace.

    Raises
    ------
    InputError
        An unknown backend, ``"cholmod"`` without scikit-sparse or ``"pardiso"`` without MKL.
    """

    def __init__(self, K, M, prefer: str | None = None, backend: str | None = None):
        if prefer not in (None, "band", "sparse"):
            raise ValueError(f"prefer={prefer!r}: give None, 'band' or 'sparse'")
        self.prefer = prefer
        self.backend = _backend(backend)
        self.pattern = Pattern(K, M)
        self.n = self.pattern.n
        self.n_factorisations = 0
        self._route: Route | None = None  # chosen by the first factorisation

    @property
    def route(self) -> str | None:
        """``"band"``, ``"cholmod"``, ``"pardiso"`` or ``"superlu"`` once the first factorisation has chosen
        (None before)."""
        return None if self._route is None else self._route.name

    @property
    def bandwidth(self) -> int | None:
        """Half-bandwidth of the band ordering (once the route is chosen)."""
        return None if self._route is None else self._route.bandwidth

    def matches(self, K, M) -> bool:
        """True when K and M are CSR arrays with exactly the workspace's patterns."""
        return self.pattern.matches(K, M)

    def factor(self, K, M, sigma: float = 0.0) -> Factor:
        """A factorisation of K − σM.

        The first call factorises by the backend and chooses the route
        (:func:`~.routes.choose_route`); every later one goes by that route, under its BLAS
        phase (:mod:`femupdate._threads`: a large band, PARDISO or CHOLMOD factor is a dense kernel, the
        rest one thread).

        Parameters
        ----------
        K, M : scipy.sparse.csr_array
            With the workspace's patterns (:meth:`matches`).
        sigma : float
            The shift.

        Returns
        -------
        Factor
            :class:`BandCholesky`, :class:`PardisoFactor`, :class:`CholmodFactor`, :class:`OrderedLU`, or (the first
            call with SuperLU) :class:`SuperLUFactor`.

        Raises
        ------
        NotPositiveDefinite
            Band, PARDISO or CHOLMOD route: K − σM is not positive definite.
        RuntimeError
            SuperLU finds the matrix exactly singular.
        """
        route = self._route
        with blas_phase("solve" if route is None else route.phase()):
            self.n_factorisations += 1
            if route is None:
                self._route, first = choose_route(self.pattern, K, M, sigma, self.backend, self.prefer)
                return first
            return route.factor(K, M, sigma)


_backend = backend  # the function, under a name that SparseWorkspace's parameter does not hide


def factor_name(factor) -> str:
    """What a factorisation is, for reports: ``"band Cholesky"``, ``"PARDISO Cholesky"``,
    ``"CHOLMOD Cholesky"`` or ``"SuperLU"``.

    Parameters
    ----------
    factor : Factor or scipy.sparse.linalg.SuperLU
        A factorisation from :func:`factorize` or :meth:`SparseWorkspace.factor` (SciPy's own
        SuperLU is named as such).

    Returns
    -------
    str
    """
    return factor.name if isinstance(factor, Factor) else "SuperLU"


_WORKSPACES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def workspace_of(model, K, M) -> SparseWorkspace | None:
    """The (cached) workspace of ``model`` for K and M, or None when they do not have the
    pattern the model assembles onto (then nothing is reused).

    Parameters
    ----------
    model : Model
        The key of the cache (weakly held: the workspace goes with the model).
    K, M : scipy.sparse.csr_array
        The model's matrices at some parameter values.

    Returns
    -------
    SparseWorkspace or None
        Made on the first call, with the process's backend
        (:attr:`femupdate.settings.Settings.factorisation`).
    """
    ws = _WORKSPACES.get(model)
    if ws is None:
        if not (sp.issparse(K) and K.format == "csr" and sp.issparse(M) and M.format == "csr"):
            return None
        ws = SparseWorkspace(K, M)
        _WORKSPACES[model] = ws
    return ws if ws.matches(K, M) else None
