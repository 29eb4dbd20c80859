""":class:`~femupdate.structure.Structure`'s rigid links, equal-dof ties and point masses (the
methods; their mechanics in :mod:`femupdate.structure.links`)."""

from __future__ import annotations

from collections.abc import Sequence

from .links import add_link, add_point_mass


class LinkMethods:
    """Rigid links, ties and point masses; mixed into :class:`~femupdate.structure.Structure`."""

    def rigid_link(self, independent, dependent, dofs: Sequence[str] | None = None, where: str = "rigid link") -> None:
        """Join nodes rigidly to an independent node: an exact multipoint constraint (never a penalty).

        Each dependent node d follows node i as a rigid body: ``u_d = u_i + θ_i × (x_d − x_i)``,
        ``θ_d = θ_i`` (OpenSees ``rigidLink('beam', i, d)``, Nastran RBE2).  The dependent dofs
        are eliminated: the model keeps the independent ones, ``K = Tᵀ K T`` for K0 and every
        parameter matrix (:mod:`femupdate.constraints`), and recovers the dependent ones for shapes.

        Parameters
        ----------
        independent : int or str
            The independent node; its dofs that no element uses but the link needs become model dofs.
        dependent : int, str or sequence of them
            The dependent node(s) (a rigid spider: several).
        dofs : sequence of str, optional
            The dependent dofs constrained (``"x"``, ..., ``"rz"`` or 1-6, as RBE2's CM); default
            every dof the dependent node has.
        where : str, default ``"rigid link"``
            Name of the link in messages.

        Raises
        ------
        InputError
            A node linked to itself or listed twice, a bad direction; at :meth:`build`: an undefined
            node, a dof dependent twice, a chain or loop of constraints, a supported dependent dof
            whose independent dofs are free.
        """
        add_link(self, "rigid", independent, dependent, dofs, where)

    def equal_dofs(self, independent, dependent, dofs: Sequence[str] | None = None, where: str = "equal dofs") -> None:
        """Tie dofs: ``d:dir = i:dir`` for each direction (OpenSees ``equalDOF``), an exact constraint.

        Parameters
        ----------
        independent : int or str
            The independent node.
        dependent : int, str or sequence of them
            The dependent node(s).
        dofs : sequence of str, optional
            The directions tied (``"x"``, ..., ``"rz"`` or 1-6); each must exist at the dependent node.
            Default: every dof the dependent node has (Abaqus ``*MPC`` TIE).
        where : str, default ``"equal dofs"``
            Name of the tie in messages.

        Raises
        ------
        InputError
            As :meth:`rigid_link`.
        """
        add_link(self, "equal", independent, dependent, dofs, where)

    def point_mass(self, node, m, offset: Sequence[float] | None = None, inertia=None, where: str = "point mass") -> None:
        """A rigid mass at a node: mass m whose centre is at ``offset`` from it, inertia about its centre.

        With no offset and no inertia it adds m to the node's three translations; otherwise to its
        six dofs, ``M = m [[I, -S], [S, -S²]] + [[0, 0], [0, J]]`` (S the cross-product matrix of
        the offset; Nastran CONM2).

        Parameters
        ----------
        node : int or str
            The node.
        m : float or str
            Mass (kg) or the name of a declared parameter.
        offset : sequence of 3 float, optional
            Position of the centre of mass relative to the node (m), global axes.
        inertia : array_like, shape ``(3, 3)`` or ``(6,)``, optional
            Inertia tensor about the centre of mass (kg·m²), global axes, or its lower triangle
            ``[J11, J21, J22, J31, J32, J33]`` (tensor entries: a product of inertia enters with
            its sign, J21 = −∫xy dm).
        where : str, default ``"point mass"``
            Name of the mass in messages.

        Raises
        ------
        InputError
            A malformed offset, an inertia that is not symmetric positive semi-definite, and as
            :meth:`mass`.
        """
        add_point_mass(self, node, m, offset, inertia, where)


__all__ = ["LinkMethods"]
