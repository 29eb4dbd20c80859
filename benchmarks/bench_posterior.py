"""Benchmark: the cost of a posterior — likelihood evaluations per second, and the time to an
effective sample size of 1,000 — against a plain loop over SciPy eigen-solutions, in the same run.

Usage::

    python benchmarks/bench_posterior.py            # 10-storey building, 10 parameters, ESS 1,000
    python benchmarks/bench_posterior.py --quick    # 6 storeys, ESS 200 (smoke test)

The problem: a shear building (:func:`femupdate.generators.shear_building`) of ``--storeys``
storeys with one stiffness per storey (true stiffnesses ``2e7 (1 - 0.4 (r - 1)/(N - 1))`` N/m,
floor masses 1e4 kg, bounds [0.5, 2] × the truth, uniform priors), its lowest 4 modes measured at
5 floors (1, 3, 5, 8, 10 for 10 storeys) with 0.5 % noise on the eigenvalues and 0.01 on the
unit-length shapes, stated as their standard deviations (seeded).

(1) Likelihood evaluations per second at the same 4,096 points drawn around the posterior:

    (f) ``femupdate.bayes.Posterior.log_likelihood`` — the updating core's residuals on the compiled
        route, all points at once, over the cores;
    (l) the same posterior on femupdate's local route (one ``Problem.residuals`` per point);
    (a) the baseline: a plain Python loop over the points, each with ``scipy.linalg.eigh`` of the
        assembled dense K, M and the residuals written with NumPy (benchmarks/bench_multistart.py's
        ``PlainResiduals``: relative eigenvalue errors, unit-length shapes, pairs by order),
        divided by the stated standard deviations.

    The routes' log likelihoods agree to round-off (checked).

(2) Time to an effective sample size of 1,000 for every parameter with emcee: 2 ensembles of 40
    walkers (4 L, the usual choice) and of 80 walkers (femupdate's default for 10 parameters on the
    compiled route) run 5,000 steps — long enough for a reliable autocorrelation time (50 τ) —
    started from the same draws
    of femupdate's Laplace approximation; the smallest ESS over the parameters by
    :func:`femupdate.bayes.effective_sample_size` after a burn-in of a quarter of the steps; the
    time to ESS 1,000 is the run's time × 1,000 / ESS:

    (f) ``femupdate.posterior(..., method="mcmc")`` — every half-ensemble's proposals evaluated
        at once on the compiled route; its sampling time (it also reports the search for
        solutions and the Laplace step before it);
    (a) emcee with the baseline likelihood, one walker at a time (``vectorize=False``), the same
        walkers and steps.

BLAS pinned to one thread before NumPy is imported (``--blas-threads``), as in the other
benchmarks.  Results go to ``benchmarks/results/bench_posterior.json`` (``_quick`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="6 storeys, ESS 200 (smoke test)")
    ap.add_argument("--storeys", type=int, default=None)
    ap.add_argument("--target-ess", type=float, default=None)
    ap.add_argument("--points", type=int, default=4096, help="points of the evaluation-rate test")
    ap.add_argument("--walkers", type=int, nargs="+", default=None,
                    help="walkers per ensemble of the time-to-ESS runs (default 40, emcee's usual 4 L, and 80, "
                         "femupdate's default for 10 parameters on the compiled route)")
    ap.add_argument("--steps", type=int, nargs="+", default=None,
                    help="steps of each of those runs (default 5000: at least 50 autocorrelation times)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--blas-threads", type=int, default=1)
    ap.add_argument("--output", default=None)
    return ap.parse_args(argv)


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _probes import pin_blas, write_results  # noqa: E402

ARGS = _parse() if __name__ == "__main__" else None
ENV_FOUND = pin_blas(ARGS.blas_threads if ARGS is not None else 0)  # must precede the NumPy import

import time  # noqa: E402

import numpy as np  # noqa: E402

if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
import femupdate as fu  # noqa: E402
from bench_multistart import PlainResiduals  # noqa: E402
from femupdate.bayes import Posterior, effective_sample_size  # noqa: E402
from femupdate.generators import shear_building  # noqa: E402

SIGMA_LAM, SIGMA_SHAPE = 0.005, 0.01
ENSEMBLES, SEGMENT = 2, 250


def problem(n: int, seed: int):
    """The model, its noisy test data (stated std) and the truth."""
    r = np.arange(n)
    k_true = 2.0e7 * (1.0 - 0.4 * r / max(n - 1, 1))
    model = shear_building(n, k=k_true, m=1.0e4, bounds=(0.5, 2.0)).build()
    floors = sorted(set(np.linspace(1, n, 5).round().astype(int)))
    sensors = [f"{i}:x" for i in floors]
    mm = fu.model_modes(model)
    pos = model.dof_index(sensors)
    rng = np.random.default_rng(seed)
    modes = []
    for j in range(4):
        phi = mm.shapes[pos, j] / np.linalg.norm(mm.shapes[pos, j])
        modes.append(fu.MeasuredMode(mm.eigenvalues[j] * (1 + SIGMA_LAM * rng.standard_normal()), sensors,
                                     phi + SIGMA_SHAPE * rng.standard_normal(len(sensors)),
                                     std_eigenvalue=SIGMA_LAM, std_shape=SIGMA_SHAPE))
    return model, fu.TestData(modes=tuple(modes)), k_true


class PlainLogLikelihood:
    """The baseline's log likelihood of x (stiffnesses / truth): the plain residuals divided by the
    stated standard deviations, −½‖r‖² − m/2 log 2π, −inf outside the bounds."""

    def __init__(self, model, data):
        self.res = PlainResiduals(model, data, model.values)
        T = len(data.modes)
        self.w = np.concatenate([np.full(T, 1 / SIGMA_LAM), np.full(T * len(data.modes[0].dofs), 1 / SIGMA_SHAPE)])
        lo, hi = model.bounds
        self.lo, self.hi = lo / model.values, hi / model.values
        self.const = -0.5 * self.w.size * np.log(2 * np.pi)

    def __call__(self, x):
        if np.any(x < self.lo) or np.any(x > self.hi):
            return -np.inf
        r = self.res(x) * self.w
        return -0.5 * float(r @ r) + self.const


def rate(fn, X, repeat=1):
    t = time.perf_counter()
    for _ in range(repeat):
        out = fn(X)
    return X.shape[0] * repeat / (time.perf_counter() - t), out


def ess_min(chain):
    """The smallest ESS over the parameters of chains (E, n, W, L) after a quarter burn-in, and
    whether the chains are at least 50 autocorrelation times long for every parameter."""
    kept = chain[:, chain.shape[1] // 4:]
    ess, _, reliable = effective_sample_size(kept)
    return float(np.min(ess)), bool(np.all(reliable))


def baseline_mcmc(plain, start, steps, seed):
    """emcee with the plain likelihood, one walker at a time, ``steps`` steps per ensemble."""
    import emcee

    E, W, L = start.shape
    t0 = time.perf_counter()
    chains, acc = [], []
    for e in range(E):
        s = emcee.EnsembleSampler(W, L, plain)
        s._random = np.random.RandomState(seed + e)
        s.run_mcmc(start[e], steps, progress=False)
        chains.append(s.get_chain())
        acc.append(s.acceptance_fraction.mean())
    seconds = time.perf_counter() - t0
    ess, reliable = ess_min(np.stack(chains))
    return seconds, ess, reliable, float(np.mean(acc))


def main(args) -> dict:
    n = args.storeys or (6 if args.quick else 10)
    args.walkers = args.walkers or ([24] if args.quick else [40, 80])
    args.steps = args.steps or ([600] if args.quick else [5000, 5000])
    target = args.target_ess or (200.0 if args.quick else 1000.0)
    model, data, k_true = problem(n, args.seed)
    out: dict = {"storeys": n, "parameters": n, "target_ess": target, "blas_threads": args.blas_threads,
                 "environment_found": ENV_FOUND}
    t = time.perf_counter()
    fu.posterior(model, data, method="laplace", starts=2, samples=10)  # loads the compiled code
    out["first_call_seconds"] = time.perf_counter() - t
    # ---------------------------------------------------------------- (1) evaluations per second
    post = Posterior(model, data)
    local = Posterior(model, data, route="local")
    plain = PlainLogLikelihood(model, data)
    rng = np.random.default_rng(args.seed)
    lap = fu.posterior(model, data, method="laplace", starts=8, samples=args.points, seed=args.seed)
    X = post.from_p(lap.samples)
    r_f, ll_f = rate(post.log_likelihood, X, repeat=3)
    r_l, ll_l = rate(local.log_likelihood, X[:512])
    r_a, ll_a = rate(lambda Y: np.array([plain(y) for y in Y]), X[:1024])
    agree = max(float(np.max(np.abs(ll_l - ll_f[:512]))), float(np.max(np.abs(ll_a - ll_f[:1024]))))
    out["evaluations_per_second"] = {"femupdate_compiled": r_f, "femupdate_local": r_l, "plain_scipy_loop": r_a,
                                     "ratio_compiled_over_plain": r_f / r_a, "max_log_likelihood_difference": agree}
    print(f"likelihood evaluations/s: compiled {r_f:,.0f}, local {r_l:,.0f}, plain SciPy loop {r_a:,.0f} "
          f"(ratio {r_f / r_a:.1f}x; log likelihoods agree to {agree:.1e})")
    post.close()
    # ---------------------------------------------------------------- (2) time to ESS
    out["time_to_ess"] = {}
    for walkers, steps in zip(args.walkers, args.steps):
        res = fu.posterior(model, data, method="mcmc", walkers=walkers, ensembles=ENSEMBLES, steps=steps,
                           segment=steps, starts=8, seed=args.seed)
        sampling = res.diagnostics["mcmc_seconds"]
        f_ess = min(res.diagnostics["ess"].values())
        f_ok = all(res.diagnostics["tau_reliable"].values())
        # the same start for the baseline: femupdate's walkers' initial positions
        start = post.from_p(res.chain[:, 0].reshape(-1, n)).reshape(ENSEMBLES, walkers, n)
        b_time, b_ess, b_ok, b_acc = baseline_mcmc(plain, start, steps, args.seed)
        f_t, b_t = sampling * target / f_ess, b_time * target / b_ess
        out["time_to_ess"][str(walkers)] = {
            "steps": steps,
            "femupdate": {"seconds": sampling, "ess_min": f_ess, "tau_reliable": f_ok,
                          "seconds_to_target": f_t, "seconds_search_and_laplace": res.seconds - sampling,
                          "acceptance": res.diagnostics["acceptance"], "evaluations": res.diagnostics["evaluations"],
                          "rhat_max": max(res.diagnostics["rhat"].values())},
            "plain_scipy_loop": {"seconds": b_time, "ess_min": b_ess, "tau_reliable": b_ok, "seconds_to_target": b_t,
                                 "acceptance": b_acc},
            "ratio": b_t / f_t,
        }
        print(f"{ENSEMBLES} x {walkers} walkers x {steps} steps: femupdate {sampling:.1f} s, ESS {f_ess:.0f} -> "
              f"{f_t:.1f} s to ESS {target:.0f} (+{res.seconds - sampling:.1f} s search and Laplace); plain SciPy loop "
              f"{b_time:.1f} s, ESS {b_ess:.0f} -> {b_t:.1f} s; ratio {b_t / f_t:.1f}x"
              + ("" if f_ok and b_ok else " (chains shorter than 50 tau: ESS uncertain)"))
    k_med = np.array([res.median[f"k_{i + 1}"] for i in range(n)])
    out["posterior"] = {"median_over_truth": (k_med / k_true).tolist(),
                        "std_over_truth": [res.std[f"k_{i + 1}"] / k_true[i] for i in range(n)]}
    return out


def table(res: dict) -> str:
    e = res["evaluations_per_second"]
    lines = [f"likelihood evaluations per second: compiled {e['femupdate_compiled']:,.0f}, local "
             f"{e['femupdate_local']:,.0f}, plain SciPy loop {e['plain_scipy_loop']:,.0f} "
             f"(ratio {e['ratio_compiled_over_plain']:.1f}x)"]
    for w, t in res["time_to_ess"].items():
        lines.append(f"time to ESS {res['target_ess']:.0f}, {ENSEMBLES} x {w} walkers: femupdate "
                     f"{t['femupdate']['seconds_to_target']:.1f} s, plain SciPy loop "
                     f"{t['plain_scipy_loop']['seconds_to_target']:.1f} s (ratio {t['ratio']:.1f}x)")
    return "\n".join(lines)


if __name__ == "__main__":
    write_results(main(ARGS), "bench_posterior", ARGS.quick, ARGS.output, table, None)
