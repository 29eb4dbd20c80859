"""The compiled batched route of the updating core: many starts or data sets of one small model
at once (see :mod:`.driver`); :func:`least_squares_batch`, SciPy's trf for many problems of any
Python residual function (:mod:`.lsq`)."""

from .driver import AUTO_MAX_DOFS, BatchedProblem, Evaluation, concatenate, supports, unsupported
from .starts import BatchRun, multistart_batched
from .lsq import FAILED, BatchLSQResult, least_squares_batch

__all__ = ["AUTO_MAX_DOFS", "FAILED", "BatchRun", "BatchLSQResult", "BatchedProblem",
           "Evaluation", "concatenate", "least_squares_batch", "multistart_batched", "supports", "unsupported"]
