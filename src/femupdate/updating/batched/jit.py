"""How the batched route's code is compiled: numba, cached on disk, NumPy's error model (a
division by zero gives inf or NaN, which the kernels test, not an exception), the GIL released."""

from __future__ import annotations

from numba import njit

#: entry points, called from Python
jit = njit(cache=True, error_model="numpy", nogil=True, no_cfunc_wrapper=True)
#: functions only compiled code calls: no wrapper for calls from Python (less to build; numba's
#: type hints omit this option)
inner = njit(cache=True, error_model="numpy", nogil=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)  # type: ignore[call-overload]

__all__ = ["jit", "inner"]
