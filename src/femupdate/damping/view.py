"""A damped model as the updating engine sees a model: one list of parameters (the model's,
then the damping parameters), their bounds, free set and look-ups.

The updating engine (:mod:`femupdate.updating`: the parametrisation, the solver, the
diagnostics, multi-start, the result records) reads a model through a few members —
``parameters``, ``parameter_names``, ``parameter_index``, ``parameter_indices``, ``resolve``,
``bounds``, ``free``, ``positive``, ``name``, ``dofs``, ``n_dofs``, ``dof_index``.
:class:`DampedView` offers them over :attr:`DampedModel.all_parameters
<femupdate.damping.DampedModel.all_parameters>`, so that the damped blocks
(:mod:`femupdate.updating.damped`) run through the same engine as the undamped ones.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._errors import InputError
from .model import DampedModel


class DampedView:
    """The engine's view of a :class:`DampedModel` (its parameters: the model's, then damping's).

    Parameters
    ----------
    damped : DampedModel

    Attributes
    ----------
    damped : DampedModel
    model : Model
        The undamped model (K, M and its parameters).
    parameters : tuple of Parameter
        :attr:`DampedModel.all_parameters`.
    damping_names : tuple of str
        The damping parameters' names.
    """

    def __init__(self, damped: DampedModel):
        if not isinstance(damped, DampedModel):
            raise InputError(f"DampedView: expected a DampedModel, got {type(damped).__name__}")
        self.damped = damped
        self.model = damped.model
        self.parameters = damped.all_parameters
        self.damping_names = tuple(p.name for p in damped.parameters)

    # the members the engine reads ------------------------------------------------------------
    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def dofs(self) -> tuple[str, ...]:
        """The model's dof labels."""
        return self.model.dofs

    @property
    def n_dofs(self) -> int:
        """Number of dofs."""
        return self.model.n_dofs

    @property
    def nodes(self):
        """The model's nodes (None for a matrix model)."""
        return getattr(self.model, "nodes", None)

    @property
    def positive(self) -> frozenset:
        """Parameters that must stay > 0 (the model's)."""
        return self.model.positive

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter's name, the model's then the damping parameters'."""
        return tuple(p.name for p in self.parameters)

    @property
    def values(self) -> np.ndarray:
        """Nominal values."""
        return np.array([p.value for p in self.parameters], dtype=float)

    @property
    def free(self) -> np.ndarray:
        """Indices of the parameters not ``fixed``."""
        return np.array([j for j, p in enumerate(self.parameters) if not p.fixed], dtype=np.intp)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of every parameter (damping parameters bounded below by 0)."""
        return (np.array([p.bounds[0] for p in self.parameters], dtype=float),
                np.array([p.bounds[1] for p in self.parameters], dtype=float))

    def parameter_index(self, name: str) -> int:
        """Position of a parameter (model's or damping's)."""
        try:
            return self.parameter_names.index(name)
        except ValueError:
            raise InputError(f"parameter {name!r} is not in damped model {self.name!r} (its parameters: "
                             f"{', '.join(self.parameter_names) or 'none'})") from None

    def parameter_indices(self, names: Sequence[str], what: str = "parameters") -> list[int]:
        """Positions of ``names``, each named once."""
        twice = sorted({n for n in names if list(names).count(n) > 1})
        if twice:
            raise InputError(f"{what}: parameter(s) listed twice: {', '.join(twice)}")
        return [self.parameter_index(n) for n in names]

    def resolve(self, values=None) -> np.ndarray:
        """Every parameter's value (:meth:`DampedModel.resolve`)."""
        return self.damped.resolve(values)

    def dof_index(self, labels: Sequence[str], what: str = "data") -> np.ndarray:
        """Matrix positions of dof labels (:meth:`femupdate.Model.dof_index`)."""
        return self.model.dof_index(labels, what)

    def is_damping(self, name: str) -> bool:
        """Whether ``name`` is a damping parameter."""
        return name in self.damping_names

    def __repr__(self) -> str:
        return f"DampedView({self.damped!r})"


def as_view(model) -> DampedView | None:
    """The engine's view of a damped model (a :class:`DampedModel` or a view), else None."""
    if isinstance(model, DampedView):
        return model
    if isinstance(model, DampedModel):
        return DampedView(model)
    return None


__all__ = ["DampedView", "as_view"]
