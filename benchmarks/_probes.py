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
