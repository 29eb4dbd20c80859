"""An external FE code as a black box (docs/blackbox.md).

The code is a shell command template (:class:`Command`) or a Python callable (:class:`Function`)
that gives K and M for parameter values.  :func:`probe_model` builds a
:class:`~femupdate.Model` from its runs (affine parameters exactly; others by polynomial
coefficients), :func:`update_black_box` updates through it, re-probing near the answer until a
run of the code there reproduces the fitted model.  Runs are cached (:class:`Cache`) and run in
parallel (``jobs``, or a Dask ``scheduler``).
"""

from .loop import BlackBoxResult, update_black_box
from .probe import BlackBox, ProbeOptions, Probed, probe_model
from .runs import Cache, Command, Function, Run
from .table import load_black_box

__all__ = ["BlackBox", "BlackBoxResult", "Cache", "Command", "Function", "ProbeOptions", "Probed", "Run", "load_black_box",
           "probe_model", "update_black_box"]
