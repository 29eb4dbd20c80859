"""Property tests of the rules of the modal updating problem (:mod:`femupdate.rules`).

Each rule is checked as plain Python and compiled (a small ``numba.njit`` wrapper calling the
rule, after :mod:`femupdate.updating.batched.kernel` has registered the rules with numba),
against an independent oracle: SciPy's assignment solver, a brute-force search over pairings,
the older shape scalings of :mod:`femupdate.sensitivity.scaling`, finite differences, and the
documented formulas.  With ``NUMBA_DISABLE_JIT=1`` the wrappers run as Python.
"""

from __future__ import annotations

import itertools
import math

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.optimize import linear_sum_assignment

import femupdate.updating.batched.kernel  # noqa: F401  (registers the rules with numba)
from femupdate import rules
from femupdate._errors import NumericalError
from femupdate.sensitivity.scaling import scaled_shape

JIT_DISABLED = bool(numba.config.DISABLE_JIT)
SETTINGS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
FEW = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# ---------------------------------------------------------------------------------------------
# compiled wrappers (error_model="numpy" as in the kernel)
# ---------------------------------------------------------------------------------------------
cjit = numba.njit(error_model="numpy")


@cjit
def _assign_c(C, nr, nc, out):
    rules.assign(C, nr, nc, out)


@cjit
def _pair_by_mac_c(MAC, shaped, nm, min_mac, pairs, bad):
    return rules.pair_by_mac(MAC, shaped, nm, min_mac, pairs, bad)


@cjit
def _shape_scale_c(scaling, phs, ref):
    return rules.shape_scale(scaling, phs, ref)


@cjit
def _shape_residuals_c(scaling, phs, psi_e, ref, w, out):
    return rules.shape_residuals(scaling, phs, psi_e, ref, w, out)


@cjit
def _shape_jacobian_c(scaling, phs, dphs, psi_e, ref, w, dpdx, out):
    rules.shape_jacobian(scaling, phs, dphs, psi_e, ref, w, dpdx, out)


@cjit
def _to_p_c(code, x, scale):
    return rules.to_p(code, x, scale)


@cjit
def _dp_dx_c(code, x, scale):
    return rules.dp_dx(code, x, scale)


@cjit
def _check_spectrum_c(lam, nm, pencil_scale):
    return rules.check_spectrum(lam, nm, pencil_scale)


@cjit
def _check_distinct_c(lam, nm, t):
    return rules.check_distinct(lam, nm, t)


@cjit
def _dot_c(a, b):
    return rules.dot(a, b)


def _assign_py(C, nr, nc, out):
    rules.assign(C, nr, nc, out)


IMPL = {
    "python": dict(assign=_assign_py, pair_by_mac=rules.pair_by_mac, shape_scale=rules.shape_scale,
                   shape_residuals=rules.shape_residuals, shape_jacobian=rules.shape_jacobian, to_p=rules.to_p,
                   dp_dx=rules.dp_dx, check_spectrum=rules.check_spectrum, check_distinct=rules.check_distinct),
    "compiled": dict(assign=_assign_c, pair_by_mac=_pair_by_mac_c, shape_scale=_shape_scale_c,
                     shape_residuals=_shape_residuals_c, shape_jacobian=_shape_jacobian_c, to_p=_to_p_c,
                     dp_dx=_dp_dx_c, check_spectrum=_check_spectrum_c, check_distinct=_check_distinct_c),
}
impls = pytest.mark.parametrize("impl", sorted(IMPL))

# ---------------------------------------------------------------------------------------------
# 1. assign against scipy.optimize.linear_sum_assignment
# ---------------------------------------------------------------------------------------------


@st.composite
def cost_matrices(draw):
    nr = draw(st.integers(1, 8))
    nc = draw(st.integers(nr, 12))
    kind = draw(st.sampled_from(["float", "integer", "repeated", "wide"]))
    if kind == "float":
        el = st.floats(-100.0, 100.0, allow_nan=False, allow_infinity=False)
        return draw(hnp.arrays(np.float64, (nr, nc), elements=el))
    if kind == "integer":  # many ties
        return draw(hnp.arrays(np.int64, (nr, nc), elements=st.integers(0, 3))).astype(float)
    if kind == "wide":  # magnitudes over many decades
        el = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
        return draw(hnp.arrays(np.float64, (nr, nc), elements=el))
    k = draw(st.integers(1, nc))  # repeated columns
    base = draw(hnp.arrays(np.float64, (nr, k), elements=st.sampled_from([-1.0, 0.0, 0.5, 1.0, 2.0, 7.25])))
    cols = draw(st.lists(st.integers(0, k - 1), min_size=nc, max_size=nc))
    return np.ascontiguousarray(base[:, cols])


@impls
@SETTINGS
@given(C=cost_matrices())
@example(C=np.zeros((8, 12)))
@example(C=np.ones((8, 8)))
@example(C=np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]]))
def test_assign_matches_scipy(impl, C):
    nr, nc = C.shape
    out = np.full(nr, -1, np.int64)
    IMPL[impl]["assign"](C, nr, nc, out)
    assert np.all((out >= 0) & (out < nc)), out  # every row assigned
    assert np.unique(out).size == nr, out  # distinct columns
    rows, cols = linear_sum_assignment(C)
    best = C[rows, cols].sum()
    total = C[np.arange(nr), out].sum()
    tol = 1e-12 * (1.0 + np.abs(C).sum())
    assert abs(total - best) <= tol, (total, best)


@impls
def test_assign_reads_only_the_first_rows(impl):
    """nr < C.shape[0]: rows beyond nr (here very cheap) are ignored."""
    C = np.array([[3.0, 1.0, 2.0], [1.0, 5.0, 9.0], [-100.0, -100.0, -100.0]])
    out = np.full(2, -1, np.int64)
    IMPL[impl]["assign"](C, 2, 3, out)
    assert out.tolist() == [1, 0]


# ---------------------------------------------------------------------------------------------
# 2. pair_by_mac against a brute-force search
# ---------------------------------------------------------------------------------------------


@st.composite
def pairing_cases(draw):
    T = draw(st.integers(1, 5))
    nm = draw(st.integers(1, 6))
    extra = draw(st.integers(0, 2))  # MAC may have more columns than nm: they must be ignored
    shaped = np.array(draw(st.lists(st.booleans(), min_size=T, max_size=T)), np.bool_)
    if draw(st.booleans()):  # few distinct values: ties
        el = st.sampled_from([0.0, 0.25, 0.5, 0.75, 1.0])
    else:
        el = st.floats(0.0, 1.0, allow_nan=False)
    MAC = draw(hnp.arrays(np.float64, (T, nm + extra), elements=el))
    min_mac = draw(st.one_of(st.sampled_from([0.0, 0.5, 0.75, 0.9]), st.floats(0.0, 1.0)))
    return MAC, shaped, nm, min_mac


def _brute_force(MAC, shaped, nm, min_mac):
    """The optimal total MAC of the shaped test modes and, for every optimal assignment, the
    set of test modes it pairs below min_mac."""
    ws = [int(k) for k in np.flatnonzero(shaped)]
    best, found = -math.inf, []
    for cols in itertools.permutations(range(nm), len(ws)):
        total = sum(MAC[k, j] for k, j in zip(ws, cols))
        found.append((total, cols))
        best = max(best, total)
    fails = {frozenset(k for k, j in zip(ws, cols) if not MAC[k, j] >= min_mac)
             for total, cols in found if total >= best - 1e-12}
    return ws, best, fails


@impls
@SETTINGS
@given(case=pairing_cases())
@example(case=(np.array([[0.9, 0.2], [0.1, 0.8]]), np.array([True, True]), 2, 0.5))
@example(case=(np.array([[0.9, 0.2], [0.1, 0.3]]), np.array([True, True]), 2, 0.5))
@example(case=(np.array([[0.9, 0.2], [0.0, 0.0], [0.0, 0.0]]), np.array([True, False, False]), 2, 0.5))
@example(case=(np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]), np.array([False, False, False]), 3, 0.5))
def test_pair_by_mac_brute_force(impl, case):
    MAC, shaped, nm, min_mac = case
    T = shaped.size
    pairs = np.full(T, -7, np.int64)
    bad = np.zeros(T, np.bool_)
    code, i = IMPL[impl]["pair_by_mac"](MAC, shaped, nm, min_mac, pairs, bad)
    code, i = int(code), int(i)
    ws = [int(k) for k in np.flatnonzero(shaped)]
    unshaped = [int(k) for k in np.flatnonzero(~shaped)]
    if len(ws) > nm:  # more shaped test modes than model modes
        assert (code, i) == (rules.E_NO_PAIR, nm)
        assert bad.tolist() == shaped.tolist()
        return
    ws, best, fails = _brute_force(MAC, shaped, nm, min_mac)
    if code == rules.E_NO_PAIR:
        assert i == nm
        assert frozenset(np.flatnonzero(bad).tolist()) in fails  # the failures of an optimal assignment
        assert bad.any()
        assert frozenset() not in fails or len(fails) > 1  # (an exact tie may pick a failing optimum)
        return
    assert frozenset() in fails, "an OK pairing where every optimal assignment fails min_mac"
    assert not bad.any()
    cols = pairs[ws]
    assert np.unique(cols).size == len(ws)
    assert np.all((cols >= 0) & (cols < nm))
    assert all(MAC[k, pairs[k]] >= min_mac for k in ws)
    assert abs(sum(MAC[k, pairs[k]] for k in ws) - best) <= 1e-12
    # test modes without a shape: the lowest free model modes, in order
    free = [j for j in range(nm) if j not in set(cols.tolist())]
    if len(unshaped) > len(free):
        assert (code, i) == (rules.E_NO_MODE_LEFT, unshaped[len(free)])
        assert pairs[unshaped[:len(free)]].tolist() == free
    else:
        assert (code, i) == (rules.OK, 0)
        assert pairs[unshaped].tolist() == free[:len(unshaped)]
        assert np.unique(pairs).size == T


@impls
def test_pair_by_mac_examples(impl):
    pair = IMPL[impl]["pair_by_mac"]
    # a swap: both test modes prefer model mode 0, the total is largest with 0->1, 1->0
    MAC = np.array([[0.9, 0.85, 0.0], [0.95, 0.1, 0.0]])
    pairs, bad = np.zeros(2, np.int64), np.zeros(2, np.bool_)
    assert tuple(map(int, pair(MAC, np.array([True, True]), 3, 0.5, pairs, bad))) == (rules.OK, 0)
    assert pairs.tolist() == [1, 0]
    # test mode 1 below min_mac with every model mode
    MAC = np.array([[0.9, 0.1, 0.0], [0.3, 0.2, 0.4]])
    pairs, bad = np.zeros(2, np.int64), np.zeros(2, np.bool_)
    assert tuple(map(int, pair(MAC, np.array([True, True]), 3, 0.5, pairs, bad))) == (rules.E_NO_PAIR, 3)
    assert bad.tolist() == [False, True]
    # unshaped test modes around a shaped one take the lowest free modes in order
    MAC = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.99, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    pairs, bad = np.zeros(4, np.int64), np.zeros(4, np.bool_)
    code = pair(MAC, np.array([False, True, False, False]), 4, 0.5, pairs, bad)
    assert tuple(map(int, code)) == (rules.OK, 0)
    assert pairs.tolist() == [0, 2, 1, 3]
    # one model mode too few
    pairs, bad = np.zeros(4, np.int64), np.zeros(4, np.bool_)
    code = pair(MAC, np.array([False, True, False, False]), 3, 0.5, pairs, bad)
    assert tuple(map(int, code)) == (rules.E_NO_MODE_LEFT, 3)


# ---------------------------------------------------------------------------------------------
# 3. shape scaling, residuals and their Jacobian
# ---------------------------------------------------------------------------------------------
HOW = {rules.UNIT: "unit", rules.REF: "ref", rules.MAX: "max"}


@st.composite
def shape_cases(draw):
    scaling = draw(st.sampled_from([rules.UNIT, rules.REF, rules.MAX]))
    ns = draw(st.integers(2, 8))
    L = draw(st.integers(1, 4))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    phs = rng.standard_normal(ns) * 10.0 ** rng.uniform(-3, 3)
    ref = draw(st.integers(0, ns - 1)) if scaling == rules.REF else -1
    # the test shape: near ± the model shape, or unrelated
    noise = draw(st.sampled_from([0.0, 0.1, 1.0, 10.0]))
    sgn = draw(st.sampled_from([1.0, -1.0]))
    test = sgn * phs / np.linalg.norm(phs) + noise * rng.standard_normal(ns) / np.sqrt(ns)
    w = draw(st.floats(0.1, 10.0))
    dphs = rng.standard_normal((ns, L)) * np.abs(phs).max() * 10.0 ** rng.uniform(-2, 2)
    dpdx = rng.uniform(0.1, 10.0, L)
    v = rng.standard_normal(L)
    return scaling, phs, test, ref, w, dphs, dpdx, v


def _conditioned(scaling, phs, test, ref):
    """The scaling entries of both shapes well away from zero, the largest entries well apart."""
    a = np.sort(np.abs(phs))[::-1]
    at = np.sort(np.abs(test))[::-1]
    if scaling == rules.REF:
        return abs(phs[ref]) >= 0.05 * a[0] and abs(test[ref]) >= 0.05 * at[0]
    return a[0] - a[1] >= 0.02 * a[0] and at[0] - at[1] >= 0.02 * at[0]


def _drop(x, ref):
    return np.delete(x, ref, axis=0) if ref >= 0 else x


@impls
@SETTINGS
@given(case=shape_cases())
def test_shape_residuals_and_jacobian(impl, case):
    scaling, phs, test, ref, w, dphs, dpdx, v = case
    assume(_conditioned(scaling, phs, test, ref))
    f = IMPL[impl]
    how = HOW[scaling]
    psi_e = scaled_shape(test, None, how, ref if ref >= 0 else None)[0]
    psi_a, dpsi = scaled_shape(phs, dphs, how, ref if ref >= 0 else None)
    sign = 1.0
    if scaling == rules.UNIT:
        assume(abs(psi_a @ psi_e) >= 1e-3)
        sign = -1.0 if psi_a @ psi_e < 0 else 1.0
    # the scale
    s, k, node = f["shape_scale"](scaling, phs, ref)
    assert not node
    kmax = int(np.argmax(np.abs(phs)))
    if scaling == rules.UNIT:
        assert k == kmax and math.isclose(s, np.sign(phs[kmax]) * np.linalg.norm(phs), rel_tol=1e-14)
    else:
        assert k == (ref if scaling == rules.REF else kmax) and s == phs[k]
    # the residuals: w (psi_a - psi_e), the reference entry dropped
    n = rules.n_shape_residuals(phs.size, ref)
    assert n == phs.size - (scaling == rules.REF)
    out = np.full(n, np.nan)
    assert int(f["shape_residuals"](scaling, phs, psi_e, ref, w, out)) == -1
    expected = _drop(w * (sign * psi_a - psi_e), ref)
    scale_r = w * (np.abs(psi_a).max() + np.abs(psi_e).max())
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-13 * scale_r)
    if scaling == rules.UNIT:  # the flipped model shape points along the test shape
        assert (sign * psi_a) @ psi_e > 0
    # the Jacobian: scaled_shape's derivative times w sign dpdx
    J = np.full((n, dphs.shape[1]), np.nan)
    f["shape_jacobian"](scaling, phs, dphs, psi_e, ref, w, dpdx, J)
    scale_j = w * np.abs(dphs).max() * dpdx.max() / abs(s) * (1.0 + np.abs(psi_a).max())
    np.testing.assert_allclose(J, _drop(w * sign * dpsi * dpdx, ref), rtol=0, atol=1e-12 * scale_j)
    # and central finite differences of the residuals along phs + t dphs (dpdx v)
    dvec = dphs @ (dpdx * v)
    h = 1e-6 * abs(s if scaling != rules.UNIT else phs[kmax]) / np.abs(dvec).max()
    rp, rm = np.empty(n), np.empty(n)
    assert int(f["shape_residuals"](scaling, phs + h * dvec, psi_e, ref, w, rp)) == -1
    assert int(f["shape_residuals"](scaling, phs - h * dvec, psi_e, ref, w, rm)) == -1
    fd = (rp - rm) / (2 * h)
    Jv = J @ v
    tol = 1e-6 * max(np.abs(Jv).max(), w * np.abs(dvec).max() / abs(s) * (1.0 + np.abs(psi_a).max()))
    np.testing.assert_allclose(Jv, fd, rtol=0, atol=tol)


@impls
@FEW
@given(seed=st.integers(0, 2**32 - 1), ns=st.integers(2, 8), c=st.sampled_from([0.0, 1e-14, -1e-13, 1e-12,
                                                                              -1e-12, 2e-12, -1e-11, 1e-6]),
       scaling=st.sampled_from([rules.REF, rules.MAX]), data=st.data())
def test_shape_node(impl, seed, ns, c, scaling, data):
    """A (near-)zero scaling entry is a node: shape_residuals returns its position, as
    scaled_shape raises; the unit-length scaling fails only on a shape that is zero at every
    measured dof."""
    f = IMPL[impl]
    rng = np.random.default_rng(seed)
    phs = rng.standard_normal(ns)
    if scaling == rules.REF:
        ref = data.draw(st.integers(0, ns - 1))
        k = ref
        phs[ref] = c * np.abs(np.delete(phs, ref)).max()
    else:  # MAX: the node only for a zero shape
        ref = -1
        k = 0
        phs = c * phs
        phs[0] = np.abs(phs).max() * (1.0 if c >= 0 else -1.0) if c != 0.0 else 0.0
    try:
        scaled_shape(phs, None, HOW[scaling], ref if ref >= 0 else None)
        is_node = False
    except NumericalError:
        is_node = True
    s, kk, node = f["shape_scale"](scaling, phs, ref)
    assert bool(node) == is_node and int(kk) == k
    psi_e = np.ones(ns)
    out = np.full(rules.n_shape_residuals(ns, ref), np.nan)
    assert int(f["shape_residuals"](scaling, phs, psi_e, ref, 1.0, out)) == (k if is_node else -1)
    if scaling == rules.REF:
        assert is_node == (abs(c) <= 1e-12)
    _, _, node = f["shape_scale"](rules.UNIT, phs, -1)
    assert bool(node) == (not np.any(phs))


@impls
def test_shape_node_examples(impl):
    f = IMPL[impl]
    out = np.zeros(2)
    phs = np.array([0.3, 0.0, -1.0])
    assert int(f["shape_residuals"](rules.REF, phs, np.array([1.0, 1.0, 1.0]), 1, 1.0, out)) == 1
    phs = np.array([0.3, 1e-13, -1.0])
    assert int(f["shape_residuals"](rules.REF, phs, np.array([1.0, 1.0, 1.0]), 1, 1.0, out)) == 1
    phs = np.array([0.3, 1e-11, -1.0])
    assert int(f["shape_residuals"](rules.REF, phs, np.array([1.0, 1.0, 1.0]), 1, 1.0, out)) == -1
    out = np.zeros(3)
    assert int(f["shape_residuals"](rules.MAX, np.zeros(3), np.array([1.0, 0.0, 0.0]), -1, 1.0, out)) == 0


# ---------------------------------------------------------------------------------------------
# 4. parametrisations
# ---------------------------------------------------------------------------------------------


@impls
@FEW
@given(code=st.sampled_from(sorted(rules.PARAMETRISATIONS.values())), seed=st.integers(0, 2**32 - 1),
       L=st.integers(1, 6))
def test_dp_dx_is_the_derivative_of_to_p(impl, code, seed, L):
    f = IMPL[impl]
    rng = np.random.default_rng(seed)
    x = rng.uniform(-3.0, 3.0, L)
    scale = rng.uniform(0.01, 100.0, L)
    x0 = x.copy()
    p = f["to_p"](code, x, scale)
    expected = {rules.RELATIVE: x * scale, rules.LOG: np.exp(x), rules.ABSOLUTE: x}[code]
    np.testing.assert_allclose(p, expected, rtol=1e-15)
    p[:] = 12345.0  # a new array, not a view of x or scale
    np.testing.assert_array_equal(x, x0)
    d = f["dp_dx"](code, x, scale)
    assert d.shape == (L,)
    h = 1e-6
    for j in range(L):  # column j of the Jacobian: d[j] on the diagonal, zero elsewhere
        e = np.zeros(L)
        e[j] = h
        fd = (f["to_p"](code, x + e, scale) - f["to_p"](code, x - e, scale)) / (2 * h)
        col = np.zeros(L)
        col[j] = d[j]
        np.testing.assert_allclose(fd, col, rtol=1e-8, atol=1e-8 * np.abs(d).max())
    d[:] = 12345.0
    np.testing.assert_array_equal(x, x0)
    assert not np.any(scale == 12345.0)


# ---------------------------------------------------------------------------------------------
# 5. spectrum checks
# ---------------------------------------------------------------------------------------------


@st.composite
def spectra(draw):
    nm = draw(st.integers(1, 6))
    extra = draw(st.integers(0, 2))
    mag = draw(st.sampled_from([1e-3, 1.0, 1e6]))
    pencil = draw(st.sampled_from([0.0, 1e-3, 1.0, 1e6, 1e9]))
    t = rules.RIGID_TOL
    el = st.one_of(
        st.floats(0.01, 100.0).map(lambda v: v * mag),  # flexible
        st.floats(-3 * t, 3 * t).map(lambda v: v * mag),  # around the rigid-body threshold
        st.sampled_from([0.0, -0.0, t, -t]).map(lambda v: v * mag),
        st.floats(-1.0, -0.01).map(lambda v: v * mag),  # clearly negative
    )
    lam = np.sort(np.array(draw(st.lists(el, min_size=nm + extra, max_size=nm + extra))))
    return lam, nm, pencil


@impls
@SETTINGS
@given(case=spectra())
@example(case=(np.array([-2e-12, 1.0, 2.0]), 3, 1.0))
@example(case=(np.array([-0.5e-12, 0.5e-12, 1.0]), 3, 1.0))
@example(case=(np.array([-0.5e-12, 0.5e-12, 1.0]), 3, 10.0))
@example(case=(np.array([-5e-6, 0.5e-12, 1.0]), 2, 1e9))
def test_check_spectrum(impl, case):
    lam0, nm, pencil = case
    lam = lam0.copy()
    code, low = IMPL[impl]["check_spectrum"](lam, nm, pencil)
    scale = max(pencil, 1e-300, np.abs(lam0[:nm]).max())
    lowest = min(0.0, lam0[:nm].min())
    if lowest < -1e-12 * scale:
        assert int(code) == rules.E_NEGATIVE and low == lowest
        np.testing.assert_array_equal(lam, lam0)  # untouched
        return
    assert int(code) == rules.OK
    rigid = np.abs(lam0[:nm]) <= rules.RIGID_TOL * scale
    assert np.all(lam[:nm][rigid] == 0.0) and not np.any(np.signbit(lam[:nm][rigid]))
    np.testing.assert_array_equal(lam[:nm][~rigid], lam0[:nm][~rigid])
    np.testing.assert_array_equal(lam[nm:], lam0[nm:])  # beyond nm untouched


@st.composite
def distinct_cases(draw):
    nm = draw(st.integers(1, 6))
    base = draw(st.lists(st.sampled_from([0.0, 1.0, 2.5, 1e3, 1e-9]), min_size=nm, max_size=nm))
    rel = draw(st.lists(st.sampled_from([0.0, 0.0, 1e-10, 0.5e-8, 0.999e-8, 1.001e-8, 2e-8, 1e-6]),
                        min_size=nm, max_size=nm))
    lam = np.sort(np.array([b * (1 + r) for b, r in zip(base, rel)]))
    t = draw(st.integers(0, nm - 1))
    return lam, nm, t


@impls
@SETTINGS
@given(case=distinct_cases())
@example(case=(np.array([0.0, 1.0, 1.0 + 1e-9, 2.0]), 4, 1))
@example(case=(np.array([0.0, 1.0, 1.0 + 1e-9, 2.0]), 4, 2))
@example(case=(np.array([0.0, 1.0, 1.0 + 1e-9, 2.0]), 4, 0))
@example(case=(np.array([0.0, 1.0, 1.0 + 1e-9, 2.0]), 4, 3))
@example(case=(np.array([1e8, 1e8 + 1.0, 1e8 + 3.0]), 3, 0))
def test_check_distinct(impl, case):
    lam, nm, t = case
    lam0 = lam.copy()
    code, other = IMPL[impl]["check_distinct"](lam, nm, t)
    code, other = int(code), int(other)
    np.testing.assert_array_equal(lam, lam0)
    if lam[t] == 0.0:
        assert (code, other) == (rules.E_RIGID, t)
        return
    scale = max(1e-300, np.abs(lam[:nm]).max())
    tol = rules.REPEATED_TOL * max(abs(lam[t]), 1e-12 * scale)
    partners = [j for j in range(nm) if j != t and abs(lam[j] - lam[t]) <= tol]
    if partners:
        assert (code, other) == (rules.E_REPEATED, partners[0])
    else:
        assert (code, other) == (rules.OK, t)


@impls
def test_spectrum_examples(impl):
    f = IMPL[impl]
    # the scale is max(|lambda|, pencil scale) = 2 here: the threshold is -2e-12
    lam = np.array([-3e-12, -2.5e-12, 1.0, 2.0])
    code, low = f["check_spectrum"](lam, 4, 1.0)
    assert (int(code), low) == (rules.E_NEGATIVE, -3e-12) and lam.tolist() == [-3e-12, -2.5e-12, 1.0, 2.0]
    lam = np.array([-2e-12, 1.0, 2.0])
    assert int(f["check_spectrum"](lam, 3, 1.0)[0]) == rules.OK and lam.tolist() == [0.0, 1.0, 2.0]
    # the same value is rigid against a larger pencil scale
    lam = np.array([-3e-12, 1.0, 2.0])
    assert int(f["check_spectrum"](lam, 3, 10.0)[0]) == rules.OK and lam.tolist() == [0.0, 1.0, 2.0]
    # a negative value beyond nm is not looked at
    lam = np.array([1.0, 2.0, -5.0])
    assert int(f["check_spectrum"](lam, 2, 1.0)[0]) == rules.OK and lam.tolist() == [1.0, 2.0, -5.0]
    # rigid-body values zeroed in place; a zero eigenvalue then fails check_distinct
    lam = np.array([-0.5e-12, 0.7e-12, 1.0, 1.0 + 1e-9, 3.0])
    assert int(f["check_spectrum"](lam, 5, 1.0)[0]) == rules.OK
    assert lam.tolist() == [0.0, 0.0, 1.0, 1.0 + 1e-9, 3.0]
    assert tuple(map(int, f["check_distinct"](lam, 5, 0))) == (rules.E_RIGID, 0)
    assert tuple(map(int, f["check_distinct"](lam, 5, 1))) == (rules.E_RIGID, 1)
    assert tuple(map(int, f["check_distinct"](lam, 5, 2))) == (rules.E_REPEATED, 3)
    assert tuple(map(int, f["check_distinct"](lam, 5, 3))) == (rules.E_REPEATED, 2)
    assert tuple(map(int, f["check_distinct"](lam, 5, 4))) == (rules.OK, 4)
    # "within" REPEATED_TOL: the bound itself counts (1e-8 * 1e8 == 1.0 exactly)
    lam = np.array([1e8, 1e8 + 1.0, 1e8 + 3.0])
    assert tuple(map(int, f["check_distinct"](lam, 3, 0))) == (rules.E_REPEATED, 1)
    lam = np.array([1e8, 1e8 + 1.5, 1e8 + 3.0])
    assert tuple(map(int, f["check_distinct"](lam, 3, 0))) == (rules.OK, 0)
    # only the lowest nm are looked at
    lam = np.array([1.0, 2.0, 2.0])
    assert tuple(map(int, f["check_distinct"](lam, 2, 1))) == (rules.OK, 1)


# ---------------------------------------------------------------------------------------------
# 6. the compiled inner product: a sequential sum, bit for bit
# ---------------------------------------------------------------------------------------------


def _sequential(a, b):
    s = 0.0
    for i in range(a.size):
        s += float(a[i]) * float(b[i])
    return s


def _same_bits(x, y):
    return np.array(x, np.float64).view(np.uint64) == np.array(y, np.float64).view(np.uint64)


@SETTINGS
@given(M=hnp.arrays(np.float64, hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=40),
                    elements=st.floats(-1e8, 1e8, allow_subnormal=False)
                    | st.sampled_from([0.0, -0.0, 1.0, 1e-8, 3.0, 1e16])),
       data=st.data())
def test_compiled_dot_is_a_sequential_sum(M, data):
    nr, nc = M.shape
    j = data.draw(st.integers(0, nc - 1))
    i = data.draw(st.integers(0, nr - 1))
    col = M[:, j]  # non-contiguous
    cases = [
        (np.ascontiguousarray(col), np.ascontiguousarray(col[::-1])),
        (col, col[::-1]),
        (col, np.ascontiguousarray(M[:, (j + 1) % nc])),
        (M[i], M[(i + 1) % nr]),
        (M[i, ::2], M[(i + 1) % nr, ::2]),
        (M.T[j], M[:, 0]),
    ]
    for a, b in cases:
        got = _dot_c(a, b)
        want = _sequential(a, b)
        if JIT_DISABLED:  # no compiled implementation: rules.dot is NumPy's
            assert math.isclose(got, want, rel_tol=1e-9, abs_tol=1e-9 * float(np.abs(a) @ np.abs(b)))
        else:
            assert _same_bits(got, want), (got, want, a, b)


def test_compiled_dot_order_matters():
    """A case where the sequential order changes the result (the test above can tell)."""
    a = np.array([1e16, 1.0, -1e16, 1.0, 1.0])
    b = np.ones(5)
    assert _sequential(a, b) == 2.0 and math.fsum(a) == 3.0  # 1e16 + 1 rounds to 1e16
    if not JIT_DISABLED:
        assert _dot_c(a, b) == 2.0
        assert _dot_c(np.c_[a, a][:, 1], b[::-1]) == 2.0


# ---------------------------------------------------------------------------------------------
# 7. messages
# ---------------------------------------------------------------------------------------------


def test_every_error_has_a_message():
    codes = {v for k, v in vars(rules).items() if k.startswith("E_")}
    assert codes == set(rules.ERRORS) and rules.OK not in rules.ERRORS
    for code in rules.ERRORS:
        for args in [dict(), dict(i0=2, i1=3, f0=-1.5e-3, f1=2.0, modes=[0, 4], min_mac=0.6),
                     dict(i0=np.int64(2), i1=np.int64(3), f0=np.float64(-1.5e-3), f1=np.float64(2.0),
                          modes=np.array([0, 4]), min_mac=0.6)]:
            for c in (code, np.int64(code)):
                text = rules.message(c, **args)
                assert isinstance(text, str) and text and "{" not in text and "}" not in text
    assert "modes 3 and 4" in rules.message(rules.E_REPEATED, 2, 3, 1.0, 1.0)
    assert "[1, 5]" in rules.message(rules.E_NO_PAIR, 6, modes=np.array([0, 4]), min_mac=0.6)
    assert "-0.0015" in rules.message(rules.E_NEGATIVE, f0=-1.5e-3)
    assert "test mode 3" in rules.message(rules.E_NO_MODE_LEFT, 2)


@pytest.mark.parametrize("impl", ["python", "compiled"])
def test_degenerate_inputs_fail_cleanly(impl):
    """No model mode to pair with, a zero model shape, more rows than columns: an error code or
    an unassigned row, never a wrong pair, an exception or a hang."""
    f = IMPL[impl]
    pairs, bad = np.zeros(1, np.int64), np.zeros(1, np.bool_)
    code, _ = f["pair_by_mac"](np.zeros((1, 1)), np.array([True]), 0, 0.0, pairs, bad)
    assert code == rules.E_NO_PAIR and bad[0]
    out = np.zeros(3)
    assert int(f["shape_residuals"](rules.UNIT, np.zeros(3), np.array([1.0, 0.0, 0.0]), -1, 1.0, out)) >= 0
    cols = np.zeros(2, np.int64)
    f["assign"](np.ones((2, 1)), 2, 1, cols)  # the one column takes one row, the other row is left over
    assert sorted(cols.tolist()) == [-1, 0]
    f["assign"](np.ones((2, 0)), 2, 0, cols)  # no column at all
    assert cols.tolist() == [-1, -1]
