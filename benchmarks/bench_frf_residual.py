"""Which FRF residual should be the default?  Linear, relative, log and auto residuals on
analyser-style data, measured in one run (docs/cli.md, *Choosing the FRF residual*).

The data are what an analyser exports: a frequency axis in Hz from the 0 Hz line (the DC bin,
which femupdate skips with a note) up to beyond the highest mode of interest, hundreds of evenly
spaced lines, a lightly damped structure (the model is given the same damping, so that only the
residual differs), complex noise of 1 % of each value plus a noise floor of 1e-4 of the largest
response (so that troughs and anti-resonances, three to five decades below the peaks, are mostly
noise: a wide dynamic range), the force at one dof and responses at a subset of dofs.  Three
models: a 4-dof chain (4 stiffnesses), a 6-dof chain measured at half its dofs (6 stiffnesses),
and a portal frame of beams (the column and beam moduli).  Every model is updated from the same
random starts, uniform within [0.5, 1.5] x the truth, with each residual.  Two separate questions:
does a start reach the residual's own best fit (the solution that the same residual reaches when
started at the truth: every parameter within 0.1 % of it), and how far is that best fit from the
truth (its bias and scatter under this noise)?  ``auto`` (a log-magnitude stage from the start,
then the linear residual from its solution) succeeds when it reaches the *linear* residual's best
fit: the question is whether it finds linear's unbiased minimum as often as log finds its own.
Reported per model and residual: starts reaching the best fit, the best fit's largest relative
error, median evaluations (both stages for auto) and time per start.

    python benchmarks/bench_frf_residual.py            # 20 starts per model (a few minutes)
    python benchmarks/bench_frf_residual.py --quick    # 3 starts, smoke run
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from femupdate import model_modes  # noqa: E402
from femupdate.examples import chain, portal_frame  # noqa: E402
from femupdate.frf import Damping, simulate  # noqa: E402
from femupdate.testdata import FRFData, TestData  # noqa: E402
from femupdate.updating import frf_update  # noqa: E402

RESIDUALS = ("linear", "relative", "log", "auto")
#: the fit a start of each residual must reach: its own best fit, but for "auto" the linear one
#: (its second stage is the linear residual; the question is whether the log stage finds its basin)
TARGET = {"linear": "linear", "relative": "relative", "log": "log", "auto": "linear"}
TOL = 1e-3  # a start succeeds when every parameter is within 0.1 % of the residual's best fit


def chain4():
    return chain([1.0e5, 1.8e5, 1.5e5, 1.2e5], [1.0, 1.2, 0.8, 1.1], bounds=(1e3, 1e7)), {"4:x": 1.0}, \
        ["1:x", "2:x", "3:x", "4:x"]


def chain6():
    return chain([1.0e5, 1.8e5, 1.5e5, 1.2e5, 0.9e5, 1.6e5], [1.0, 1.2, 0.8, 1.1, 0.9, 1.0], bounds=(1e3, 1e7)), \
        {"6:x": 1.0}, ["2:x", "4:x", "6:x"]


def frame():
    model = portal_frame(n_per_member=2)
    dofs = [d for d in model.dofs if d.endswith(":x") or d.endswith(":y")]
    return model, {dofs[0]: 1.0}, dofs[::2][:6]


MODELS = {"4-dof chain": chain4, "6-dof chain, 3 sensors": chain6, "portal frame": frame}


def analyser_data(model, force, response, damping, rng, lines=400, noise=0.01, floor=1e-4):
    """FRFs from 0 Hz to 1.2 x the highest mode of interest (the third, or the last) on ``lines``
    lines, with relative complex noise and an absolute noise floor."""
    mm = model_modes(model)
    f_top = 1.2 * mm.frequencies_hz[min(len(mm.frequencies_hz), 4) - 1]
    f_hz = np.linspace(0.0, f_top, lines + 1)
    # the 0 Hz line is simulated apart (a supported structure's static receptance)
    clean = simulate(model, 2 * np.pi * f_hz, force, response=response, damping=damping).response
    peak = np.max(np.abs(clean))
    shape = clean.shape
    cn = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    fl = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    x = clean * (1 + noise * cn) + floor * peak * fl
    return TestData(frf=FRFData(2 * np.pi * f_hz, force, tuple(response), x)), np.max(np.abs(clean)) / np.min(
        np.abs(clean[1:]))


def run(starts: int, seed: int) -> list[dict]:
    rows = []
    for name, build in MODELS.items():
        model, force, response = build()
        truth = np.array(model.resolve(model.values))
        names = list(model.parameter_names)
        free = [j for j, n in enumerate(names) if not model.parameters[j].fixed]
        damping = Damping(eta=0.02)
        rng = np.random.default_rng(seed)
        data, dyn = analyser_data(model, force, response, damping, rng)
        draws = [truth[free] * rng.uniform(0.5, 1.5, len(free)) for _ in range(starts)]
        targets = {}
        for kind in RESIDUALS:
            best = frf_update(model, data, x0={names[j]: truth[j] for j in free}, residual=kind, damping=damping)
            targets[kind] = np.array([best.parameters[names[j]] for j in free])
            target = targets[TARGET[kind]]
            bias = float(np.max(np.abs(targets[kind] / truth[free] - 1)))
            ok, errs, nfev, secs = 0, [], [], []
            for x0 in draws:
                t0 = time.perf_counter()
                try:
                    res = frf_update(model, data, x0=dict(zip([names[j] for j in free], x0)), residual=kind,
                                     damping=damping, max_nfev=200)
                    p = np.array([res.parameters[names[j]] for j in free])
                    err = float(np.max(np.abs(p / target - 1)))
                    nfev.append(res.nfev)
                except Exception as exc:  # noqa: BLE001 - a failed start counts as a failure
                    err = np.inf
                    print(f"  {name} {kind}: start failed: {type(exc).__name__}: {exc}", file=sys.stderr)
                secs.append(time.perf_counter() - t0)
                if err < TOL:
                    ok += 1
                    errs.append(err)
            rows.append({"model": name, "residual": kind, "lines": data.frf.omega.size, "dynamic_range": dyn,
                         "starts": starts, "success": ok, "best_fit_error": bias,
                         "median_nfev": float(np.median(nfev)) if nfev else np.nan,
                         "seconds_per_start": float(np.median(secs))})
            r = rows[-1]
            print(f"{name:24s} {kind:8s} {ok:3d}/{starts}  best fit off the truth by {bias:.2e}  "
                  f"nfev {r['median_nfev']:5.0f}  "
                  f"{r['seconds_per_start']:.2f} s/start", flush=True)
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="3 starts per model")
    ap.add_argument("--starts", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    logging.disable(logging.WARNING)  # the lines skipped near resonances, start by start
    starts = 3 if args.quick else args.starts
    t0 = time.perf_counter()
    rows = run(starts, args.seed)
    print(f"\n| model | lines | dynamic range | {' | '.join(RESIDUALS)} |")
    print("|---|---|---|" + "---|" * len(RESIDUALS))
    for name in MODELS:
        sel = [r for r in rows if r["model"] == name]
        cells = [f"{r['success']}/{r['starts']} ({100 * r['best_fit_error']:.2g} %, {r['seconds_per_start']:.2f} s)"
                 for r in sel]
        print(f"| {name} | {sel[0]['lines']} | {sel[0]['dynamic_range']:.0e} | {' | '.join(cells)} |")
    total = {k: sum(r["success"] for r in rows if r["residual"] == k) for k in RESIDUALS}
    n = sum(r["starts"] for r in rows if r["residual"] == RESIDUALS[0])
    print("\nstarts reaching the residual's best fit (within 0.1 %): "
          + ", ".join(f"{k} {v}/{n}" for k, v in total.items()))
    print("ratios against linear: " + ", ".join(f"{k} {total[k] / max(total['linear'], 1):.2f}" for k in RESIDUALS))
    print(f"auto reaches the linear best fit from {total['auto']}/{n} starts, log its own from {total['log']}/{n}")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
