"""Limits on the numbers of input files (docs/file-formats.md, "Numbers").

Every number read from a model file, test data or another input file must be at most
:data:`MAX_MAGNITUDE` in magnitude, so that its square, such as the eigenvalue (2πf)² of a
frequency, stays finite in double precision; larger values are refused when the file is read,
naming the file and the field, instead of overflowing to infinity later in a computation.
"""

from __future__ import annotations

#: largest magnitude accepted for a number in an input file
MAX_MAGNITUDE = 1e150

#: largest weighted residual accepted at the start of a least-squares solve: the solver's sums of
#: squares and products of the residuals and their Jacobian (up to fourth powers) stay finite;
#: residuals normalised by the data or their standard deviations are of order 1 to 1e6
MAX_START_RESIDUAL = 1e50
