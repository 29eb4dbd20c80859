"""Parameter documentation written once and shared by the functions that take the same
arguments (as SciPy's ``doccer``): a docstring line that holds only ``{{name}}`` is replaced by
the block ``name``, indented as the placeholder.

    @shared_docs(DERIVATIVE_ARGUMENTS=DERIVATIVE_ARGUMENTS)
    def nelson(model, modes, which=None, params=None, values=None):
        '''...

        Parameters
        ----------
        {{DERIVATIVE_ARGUMENTS}}
        '''
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable)

_PLACEHOLDER = re.compile(r"^(?P<indent>[ \t]*)\{\{(?P<name>\w+)\}\}[ \t]*$", re.MULTILINE)

#: the arguments of the eigen-derivative routes (:mod:`femupdate.sensitivity`)
DERIVATIVE_ARGUMENTS = """\
model : Model
    The model (affine in its parameters).
modes : Modes
    Mass-normalised modes of ``model`` at ``values`` (φᵀMφ = 1), e.g. from :func:`femupdate.model_modes`.
which : int or sequence of int, optional
    Indices into ``modes`` of the modes to differentiate (default all).
params : sequence of int or str, optional
    Parameters, by index or name (default the free ones); L = ``len(params)``.
values : array_like, shape ``(n_parameters,)``, optional
    Parameter values of ``modes`` (default nominal)."""

#: the eigenvector derivatives the routes return (:mod:`femupdate.sensitivity`)
DPHI = """\
dphi : numpy.ndarray, shape ``(n_dofs, len(which), L)``
    Derivatives of the mass-normalised shapes."""

#: what the eigen-derivative routes return
DERIVATIVES = """\
Returns
-------
dlam : numpy.ndarray, shape ``(len(which), L)``
    Eigenvalue derivatives dλ/dp, rad²/s² per unit of the parameter (paper eq. 21).
""" + DPHI

#: the errors of the eigen-derivative routes
DERIVATIVE_RAISES = """\
Raises
------
InputError
    Modes not mass-normalised, or a mode or parameter index out of range (an unknown
    parameter name); bad ``groups``.
NumericalError
    A rigid-body or repeated mode among ``which`` (not differentiable as such) outside
    ``groups``."""

#: the blocks of the eigen-derivative routes, for ``shared_docs(**DERIVATIVE_DOCS)``
DERIVATIVE_DOCS = {"DERIVATIVE_ARGUMENTS": DERIVATIVE_ARGUMENTS, "DPHI": DPHI, "DERIVATIVES": DERIVATIVES,
                   "DERIVATIVE_RAISES": DERIVATIVE_RAISES}

#: a method of an updating problem at the optimiser's variables x, up to its returns
#: (:mod:`femupdate.updating`): ``{{X}}`` then the returned value
X = """\
Parameters
----------
x : array_like, shape ``(L,)``
    The optimiser's variables.

Returns
-------"""

#: the model and the spectral lines of the FRF functions (:mod:`femupdate.frf`)
FRF_LINES = """\
model : Model
    The parametrised model.
omega : array_like, shape ``(n_lines,)``
    Spectral lines ω, rad/s (finite, ≥ 0)."""

#: the force of the FRF functions
FORCE = """\
force : mapping of str to float or complex
    Force amplitude (N) at each loaded dof ``"node:dir"``, {dof: amplitude}."""

#: the arguments of an FRF simulation (:mod:`femupdate.frf.simulate`)
FRF_ARGUMENTS = FRF_LINES + "\n" + FORCE + """
response : sequence of str, optional
    Dof labels of the responses kept (default every model dof).
values : None, mapping of str to float, or array_like, optional
    Parameter values as :meth:`Model.resolve` reads them (default nominal).
damping : Damping or mapping, optional
    :class:`~femupdate.frf.Damping` or {alpha, beta, eta}; default undamped."""


#: the parameters and returns of the plotting functions (:mod:`femupdate.plot`)
PLOT_DOCS = {
    "AX": "ax : matplotlib.axes.Axes, optional\n    Axes to draw on (default: a new figure).",
    "AX_RETURNED": "Returns\n-------\nmatplotlib.axes.Axes",
    "AXES_PAIR": "axes : sequence of 2 matplotlib.axes.Axes, optional\n    Default: a new figure.\n\n"
                 "Returns\n-------\nsequence of matplotlib.axes.Axes",
    "FIGURE_PATH": "path : str or os.PathLike\n    Image file; its suffix selects the format "
                   "(:func:`~femupdate.plot.paper_figures.save_figure`).",
    "FIGURE_NAME": "Returns\n-------\nstr\n    The file name (without directory).",
    "FIGURE_NAMES": "Returns\n-------\nlist of str\n    The file names written.",
}


def fill(doc: str | None, blocks: dict[str, str]) -> str | None:
    """``doc`` with each ``{{name}}`` line replaced by ``blocks[name]``, indented as the line.

    Raises
    ------
    KeyError
        A placeholder without its block (a mistake in the source, found at import).
    """
    if doc is None:
        return None

    def block(m: re.Match) -> str:
        indent = m.group("indent")
        return "\n".join(indent + line if line else line for line in blocks[m.group("name")].splitlines())

    return _PLACEHOLDER.sub(block, doc)


def shared_docs(**blocks: str) -> Callable[[F], F]:
    """A decorator filling the function's docstring with the shared ``blocks`` (:func:`fill`)."""
    def decorator(f: F) -> F:
        f.__doc__ = fill(f.__doc__, blocks)
        return f

    return decorator


__all__ = ["fill", "shared_docs", "DERIVATIVE_ARGUMENTS", "DPHI", "DERIVATIVES", "DERIVATIVE_RAISES", "DERIVATIVE_DOCS",
           "X", "FRF_LINES", "FORCE", "FRF_ARGUMENTS", "PLOT_DOCS"]
