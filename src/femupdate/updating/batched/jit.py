"""How the batched route's code is compiled: numba, cached on disk, NumPy's error model (a
division by zero gives inf or NaN, which the kernels test, not an exception), the GIL released."""

from __future__ import annotations

from numba import njit

#: entry points, called from Python (no C-callable wrapper: nothing takes their address; numba's
#: type hints omit the wrapper options)
jit = njit(cache=True, error_model="numpy", nogil=True, no_cfunc_wrapper=True)  # type: ignore[call-overload]
#: functions only compiled code calls: no wrapper for calls from Python either (less to build)
inner = njit(cache=True, error_model="numpy", nogil=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)  # type: ignore[call-overload]

__all__ = ["jit", "inner"]
