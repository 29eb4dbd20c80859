"""Shared probes of the benchmarks: wall time and resident-set peak of one phase."""

from __future__ import annotations

import gc
import resource
import sys
import time

MB = 1024.0**2


def _status_kb(field: str) -> float | None:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return float(line.split()[1])
    except OSError:
        return None
    return None


def _reset_hwm() -> bool:
    """Reset the resident-set high-water mark (Linux >= 4.0); False where not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def _maxrss_mb() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return r / 1024.0 if sys.platform != "darwin" else r / MB  # kB on Linux, bytes on macOS


class Phase:
    """Context manager: wall time and resident-set peak of one phase."""

    hwm_reset = True

    def __enter__(self):
        gc.collect()
        Phase.hwm_reset = _reset_hwm() and Phase.hwm_reset
        rss = _status_kb("VmRSS")
        self.rss0 = rss / 1024.0 if rss is not None else float("nan")
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.t0
        hwm = _status_kb("VmHWM")
        self.rss_peak = hwm / 1024.0 if hwm is not None else _maxrss_mb()
        self.rss_delta = self.rss_peak - self.rss0
        return False


BLAS_VARIABLES = ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def pin_blas(threads: int) -> dict:
    """Pin the BLAS to ``threads`` threads through the environment (0: leave it as found); call it
    before NumPy is imported.  Returns the variables as found."""
    import os

    found = {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    if threads > 0:
        for key in found:
            os.environ[key] = str(threads)
    return found


def settings_from_environment():
    """Install femupdate's settings from ``FEMUPDATE_FACTORISATION`` and ``FEMUPDATE_BLAS_THREADS``
    as the command line reads them (the library reads no environment variable); returns them."""
    import os

    from femupdate import settings
    from femupdate.cli._entry import settings_from

    chosen = settings_from(os.environ)
    settings.install(chosen)
    return chosen


def environment(**extra) -> dict:
    """Versions, machine, BLAS variables, load and date of a benchmark run (plus ``extra``)."""
    import os
    import platform

    import numpy as np
    import scipy

    import femupdate

    env = {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
           "femupdate": femupdate.__version__, "machine": platform.machine(), "cpus": os.cpu_count(),
           "environment": {k: os.environ.get(k) for k in BLAS_VARIABLES}, "rss_hwm_reset": Phase.hwm_reset,
           "load_average": os.getloadavg(), "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    env.update(extra)
    return env


def write_results(res: dict, name: str, quick: bool, output, table, argv) -> None:
    """Attach the environment and argv to ``res``, print ``table(res)`` and write the JSON to ``output``
    (default ``benchmarks/results/<name>[_quick].json``)."""
    from pathlib import Path

    res["environment"] = environment()
    res["argv"] = sys.argv[1:] if argv is None else list(argv)
    print(table(res))
    here = Path(__file__).resolve().parent
    out = save_json(res, Path(output) if output else here / "results" / (f"{name}_quick.json" if quick else f"{name}.json"))
    print(f"\nresults written to {out}")


def save_json(res: dict, out):
    """Write ``res`` as indented JSON to ``out`` (its folder made; NumPy values as lists or
    floats); returns the path."""
    import json
    from pathlib import Path

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)) + "\n")
    return out


OUTCOMES = ("truth", "other", "not-converged", "failed")


def outcomes(ms, truth, rtol: float = 1e-6):
    """Each multi-start run's outcome — ``truth`` (every parameter within ``rtol`` of ``truth``),
    ``other`` (converged elsewhere), ``not-converged`` or ``failed`` — and its solution (None when
    it failed)."""
    import numpy as np

    cls, sols = [], []
    for r in ms.runs:
        if isinstance(r, str):
            cls.append("failed")
            sols.append(None)
        elif not r.success:
            cls.append("not-converged")
            sols.append(np.asarray(r.x, float))
        else:
            err = float(np.max(np.abs(np.asarray(r.x) / truth - 1)))
            cls.append("truth" if err < rtol else "other")
            sols.append(np.asarray(r.x, float))
    return cls, sols


def count(cls) -> dict:
    """How many runs had each outcome (:data:`OUTCOMES`)."""
    return {c: cls.count(c) for c in OUTCOMES}


def multistart_cpu(ms, parent_cpu: float, model, scheduler: bool = False) -> tuple[float, int]:
    """CPU seconds of a multi-start run and the local processes it used: ``parent_cpu`` (this
    process's CPU time over the run) plus, when the starts ran in local worker processes
    (:func:`femupdate.updating.starts.local_jobs`), the CPU seconds each worker recorded for its
    starts — this process's clock does not see them.  On Dask the workers' CPU is not counted
    (``scheduler=True``: this process only)."""
    from femupdate.updating.starts import local_jobs

    jobs = 1 if scheduler else local_jobs(model, ms.total)
    if jobs > 1 and ms.cpu_seconds is not None:
        return parent_cpu + float(sum(ms.cpu_seconds)), jobs
    return parent_cpu, jobs
