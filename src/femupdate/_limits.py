"""Limits on the numbers of input files (docs/file-formats.md, "Numbers").

Every number read from a model file, test data or another input file must be at most
:data:`MAX_MAGNITUDE` in magnitude, so that its square, such as the eigenvalue (2πf)² of a
frequency, stays finite in double precision; larger values are refused when the file is read,
naming the file and the field, instead of overflowing to infinity later in a computation.
"""

from __future__ import annotations

#: largest magnitude accepted for a number in an input file
MAX_MAGNITUDE = 1e150
