"""Option groups: each group of command-line options builds one object (an option object of
:mod:`femupdate.options`, or a small specification the command resolves against its model and
data), so that a command's function takes a handful of objects instead of forty keywords, and
``--help`` lists the options under their group's heading.

A group is a decorator made by :func:`option_group`::

    @click.command(cls=GroupedCommand)
    @starts_group()           # --starts, --seed         -> starts: StartsOptions
    @execution_group()        # --scheduler, --jobs, ... -> execution: ExecutionOptions
    def update(model_path, data_path, starts, execution, ...): ...
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from typing import Any

import click

from .._errors import InputError
from ..options import ExecutionOptions, SamplerOptions, SolverOptions, StartsOptions
from ._common import SCHEDULER, SEED, FiniteFloat, connect_timeout_option


class GroupedCommand(click.Command):
    """A command whose ``--help`` lists its options under the headings of their groups."""

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        sections: dict[str, list[tuple[str, str]]] = {}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None:
                sections.setdefault(getattr(param, "group", None) or "Other options", []).append(record)
        for title, rows in sections.items():
            with formatter.section(title):
                formatter.write_dl(rows)


def option_group(title: str, target: str, build: Callable[..., Any], *options: Callable,
                 applies: dict[str, tuple[str, tuple[str, ...]]] | None = None) -> Callable:
    """A decorator that adds ``options`` (click option decorators, listed as they appear in
    ``--help``) to a command under the heading ``title`` and passes ``build(**their values)`` to
    the command's function as the keyword ``target`` instead of the values themselves.

    An option that does nothing with the others given is refused rather than ignored: ``applies``
    maps an option's name to ``(other, values)``, and giving it on the command line while the
    option ``other`` is not one of ``values`` is an error (``--walkers applies to --method mcmc
    only, not --method laplace``).

    Parameters
    ----------
    title : str
        The heading of the group in ``--help``.
    target : str
        The keyword the built object is passed as.
    build : callable
        Called with the group's parameters by name; returns the object.
    *options : click option decorators
    applies : dict, optional
        ``{name: (other, values)}``: ``name`` applies only when ``other`` is one of ``values``.
    """
    def probe() -> None:  # pragma: no cover - never called
        pass

    for option in reversed(options):
        probe = option(probe)
    params = list(getattr(probe, "__click_params__", []))
    names = [p.name for p in params]
    for p in params:
        setattr(p, "group", title)

    def decorator(f: Callable) -> Callable:
        @functools.wraps(f)
        def wrapper(*args, **kwargs):
            values = {n: kwargs.pop(n) for n in names}
            try:
                _refuse_unused(values, applies or {}, params)
                kwargs[target] = build(**values)
            except InputError as exc:  # a field named as the command line spells it
                raise InputError(spelled(str(exc), params)) from None
            return f(*args, **kwargs)

        wrapper.__click_params__ = list(getattr(f, "__click_params__", [])) + params  # type: ignore[attr-defined]
        return wrapper

    return decorator


def _refuse_unused(values: dict, applies: dict[str, tuple[str, tuple[str, ...]]], params) -> None:
    """Refuse an option given on the command line that ``applies`` says does nothing with the
    values of the others (see :func:`option_group`)."""
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return
    spelling = {p.name: max(p.opts, key=len) for p in params}
    for name, (other, allowed) in applies.items():
        if ctx.get_parameter_source(name) in (click.core.ParameterSource.COMMANDLINE,
                                               click.core.ParameterSource.ENVIRONMENT) \
                and values[other] not in allowed:
            raise InputError(f"{spelling[name]} applies to {spelling[other]} {' or '.join(allowed)} only, not "
                             f"{spelling[other]} {values[other]}")


def spelled(message: str, params) -> str:
    """``message`` of an option object's check with its fields written as the options of
    ``params``: ``starts=N`` anywhere as ``--starts N``, a leading ``samples must be`` as
    ``--samples must be``."""
    for p in params:
        opt = max(p.opts, key=len)
        message = re.sub(rf"(?<![\w-]){re.escape(p.name)}=", f"{opt} ", message)
        if message.startswith(f"{p.name} "):
            message = opt + message[len(p.name):]
    return message


# ---------------------------------------------------------------------------------- groups
def starts_group(default: int = 1, starts_help: str | None = None, seed_help: str | None = "Seed of the random starts.",
                 title: str = "Starts", alpha: bool = True) -> Callable:
    """``--starts``, ``--seed`` and (where solutions are told apart: ``alpha``) ``--alpha`` -> ``starts``:
    :class:`~femupdate.options.StartsOptions`."""
    options = [click.option("--starts", type=click.IntRange(min=1), default=default, show_default=True,
                            help=starts_help or "1: start from the model's values; R > 1: R random starts within the "
                                                "bounds."),
               click.option("--seed", type=SEED, default=0, show_default=True, help=seed_help)]
    if not alpha:
        return option_group(title, "starts", lambda starts, seed: StartsOptions(starts=starts, seed=seed), *options)
    return option_group(
        title, "starts", lambda starts, seed, alpha: StartsOptions(starts=starts, seed=seed, alpha=alpha), *options,
        click.option("--alpha", type=FiniteFloat(min=0, max=1, min_open=True, max_open=True), default=0.01,
                     show_default=True,
                     help="Significance level at which two solutions are told apart: distinct only when they differ "
                          "significantly against their own covariances (StartsOptions.alpha)."),
    )


def execution_group(jobs: bool = True, scheduler_help: str = "Run the starts on an existing Dask cluster "
                                                              "(tcp://host:port).") -> Callable:
    """``--scheduler``, ``--connect-timeout`` (and ``--jobs``) -> ``execution``:
    :class:`~femupdate.options.ExecutionOptions`."""
    options = [
        click.option("--scheduler", type=SCHEDULER, default=None, metavar="ADDR", help=scheduler_help),
        connect_timeout_option,
    ]
    if jobs:
        options.append(click.option(
            "--jobs", type=click.IntRange(min=1, max=256), default=None,
            help="Local processes for the starts of large models (default: one per core when a start is worth a "
                 "process; 1: this process). The compiled route of small models uses threads instead."))

    def build(scheduler, connect_timeout, jobs=None):
        if jobs is not None and scheduler:
            from .._errors import InputError

            raise InputError(f"--jobs {jobs} with --scheduler: the starts run on the cluster's workers; give one of "
                             "the two")
        return ExecutionOptions(scheduler=scheduler, connect_timeout=connect_timeout, jobs=jobs)

    return option_group("Where it runs", "execution", build, *options)


def solver_group() -> Callable:
    """``--method``, ``--regularization``, ``--max-nfev`` -> ``solver``:
    :class:`~femupdate.options.SolverOptions` (its ``parametrisation`` is set by the problem's
    options, :func:`femupdate.cli.update.problem_options`)."""
    from ._common import parse_regularization

    return option_group(
        "Solver", "solver",
        lambda method, reg_text, max_nfev: SolverOptions(method=method, regularization=parse_regularization(reg_text),
                                                         max_nfev=max_nfev),
        click.option("--method", type=click.Choice(["trf", "dogbox", "lm"]), default="trf", show_default=True,
                     help="SciPy's least-squares method (lm: Levenberg-Marquardt, which ignores the bounds)."),
        click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve to choose it."),
        click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True,
                     help="The most residual evaluations."),
    )


def sampler_group() -> Callable:
    """The posterior's sampler options -> ``sampler``: :class:`~femupdate.options.SamplerOptions`."""
    def build(method, samples, walkers, ensembles, steps, burn, segment, target_ess, tmcmc_steps, chunks, level):
        return SamplerOptions(method=method, samples=samples, walkers=walkers, ensembles=ensembles, steps=steps,
                              burn=burn, segment=segment, target_ess=target_ess, tmcmc_steps=tmcmc_steps,
                              chunks=chunks, level=level)

    mcmc, tmcmc = ("method", ("mcmc",)), ("method", ("tmcmc",))
    return option_group(
        "Sampler", "sampler", build,
        click.option("--method", type=click.Choice(["laplace", "mcmc", "tmcmc"]), default="laplace", show_default=True,
                     help="laplace: a Gaussian at each solution, with its probability; mcmc: ensemble sampler (emcee) "
                          "for one solution; tmcmc: transitional MCMC for several solutions, with the log-evidence."),
        click.option("--samples", type=click.IntRange(min=2), default=4000, show_default=True,
                     help="Laplace draws, or the TMCMC population."),
        click.option("--walkers", type=click.IntRange(min=2), default=None,
                     help="MCMC walkers per ensemble (default max(64, 8 L) on the compiled route, max(32, 4 L) "
                          "otherwise)."),
        click.option("--ensembles", type=click.IntRange(min=1), default=2, show_default=True,
                     help="Independent MCMC ensembles (one Dask task each)."),
        click.option("--steps", type=click.IntRange(min=2), default=2000, show_default=True,
                     help="MCMC steps per walker."),
        click.option("--burn", type=click.IntRange(min=0), default=None, help="MCMC steps discarded (default steps / 4)."),
        click.option("--segment", type=click.IntRange(min=1), default=250, show_default=True,
                     help="MCMC steps between checkpoints (one Dask round)."),
        click.option("--target-ess", type=FiniteFloat(min=1), default=None,
                     help="Stop MCMC once every parameter's effective sample size reaches this."),
        click.option("--tmcmc-steps", type=click.IntRange(min=1), default=5, show_default=True,
                     help="Metropolis moves per chain and TMCMC stage."),
        click.option("--chunks", type=click.IntRange(min=1), default=8, show_default=True,
                     help="TMCMC's chains in this many pieces (random streams; Dask tasks)."),
        click.option("--level", type=FiniteFloat(0, 1, min_open=True, max_open=True), default=0.95, show_default=True,
                     help="Probability of the credible intervals."),
        applies={"samples": ("method", ("laplace", "tmcmc")), "walkers": mcmc, "ensembles": mcmc, "steps": mcmc,
                 "burn": mcmc, "segment": mcmc, "target_ess": mcmc, "tmcmc_steps": tmcmc, "chunks": tmcmc},
    )


__all__ = ["GroupedCommand", "option_group", "starts_group", "execution_group", "solver_group", "sampler_group"]
