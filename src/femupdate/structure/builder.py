"""The structure builder: :class:`Structure` collects parameters, nodes, elements and supports
and :meth:`Structure.build` assembles the affine sparse :class:`~femupdate.model.Model`."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._checks import str_arg
from .._errors import InputError
from ..dofs import Node, canonical, canonical_all, dof, node_id
from ..model import Model, Parameter
from .groups import BENDING, NODE_DIRS, PROPS, ElementGroup, mass_kind, per_element
from .link_methods import LinkMethods
from .tables import structure_from_dict


def _is_integer_text(v: str) -> bool:
    try:
        return isinstance(node_id(v), int)
    except InputError:
        return False


class Structure(LinkMethods):
    """Editable description of a physical-parameter structure; :meth:`build` makes the Model.

    Declare parameters, nodes, elements and supports with the methods below (or read them from
    a model file's tables with :meth:`from_dict`), then call :meth:`build`.  Element properties
    are numbers or the names of declared parameters; the model must stay affine in its
    parameters, so at most one factor of each stiffness or mass term may be a parameter.

    Parameters
    ----------
    name : str, default ``"model"``
        Name of the structure, passed on to the built :class:`~femupdate.model.Model`.
    """

    def __init__(self, name: str = "model"):
        str_arg(name, "name", "Structure", error=InputError)  # a model file's name too: bad input
        self.name = name
        self.parameters: dict[str, Parameter] = {}
        self.nodes: dict[int, tuple[float, float, float]] = {}
        self.groups: list[ElementGroup] = []
        self.supports: list[str] = []
        self.support_nodes: list[Node] = []
        self.constraints: list = []  # rigid links and ties (femupdate.structure.links.Link)
        self.units = "m-kg-s"  # the consistent unit system (a mesh declares it: femupdate.mesh.units)

    # ------------------------------------------------------------------ declarations
    def parameter(self, name: str, value: float, bounds=None, fixed: bool = False, prior=None) -> None:
        """Declare a parameter (see :class:`femupdate.Parameter`).

        Parameters
        ----------
        name : str
            Identifier, referred to by element properties.
        value : float
            Nominal / starting value, in the units of the property it stands for.
        bounds : (float, float), optional
            Lower and upper bound (default: unbounded).
        fixed : bool, default False
            A known parameter, never updated.
        prior : Prior, str or mapping, optional
            Its prior for Bayesian updating (:mod:`femupdate.priors`: ``"uniform"``,
            ``"normal(MEAN, STD)"``, ``"lognormal(MEDIAN, STD_LOG)"`` or an inline table),
            truncated to ``bounds``; default uniform within finite bounds.

        Raises
        ------
        InputError
            A name declared twice, ``fixed`` not a bool, bounds not a pair, and as
            :class:`~femupdate.model.Parameter`.
        """
        if name in self.parameters:
            raise InputError(f"parameter {name!r} declared twice")
        if not isinstance(fixed, (bool, np.bool_)):
            raise InputError(f"parameter {name!r}: fixed must be true or false, got {fixed!r}")
        try:
            b = (-math.inf, math.inf) if bounds is None else tuple(bounds)
        except TypeError:
            raise InputError(f"parameter {name!r}: bounds must be [lower, upper], got {bounds!r}") from None
        if len(b) != 2:
            raise InputError(f"parameter {name!r}: bounds must be [lower, upper], got {list(b)}")
        self.parameters[name] = Parameter(name, value, b, fixed, prior=prior)

    def node(self, node_id: int, xyz: Sequence[float]) -> None:
        """Add one node with coordinates ``xyz`` (2 or 3 numbers; z defaults to 0).

        Parameters
        ----------
        node_id : int
            Node number, used in dof labels ``"node:dir"``.
        xyz : sequence of float, length 2 or 3
            Coordinates (x, y[, z]), in the length unit of the element properties.

        Raises
        ------
        InputError
            As :meth:`add_nodes`.
        """
        self.add_nodes([node_id], [xyz])

    def add_nodes(self, ids: Sequence[int] | np.ndarray, xyz) -> None:
        """Add many nodes at once: ``ids`` (n,), ``xyz`` (n, 2 | 3).

        Parameters
        ----------
        ids : sequence of int or numpy.ndarray, shape ``(n,)``
            Node numbers.
        xyz : array_like, shape ``(n, 2)`` or ``(n, 3)``
            Coordinates; z = 0 when only two columns are given.

        Raises
        ------
        InputError
            Coordinates of the wrong shape or not finite; a node defined twice.
        """
        xyz = np.asarray(xyz, dtype=float)
        if xyz.ndim != 2 or xyz.shape[1] not in (2, 3) or xyz.shape[0] != len(ids):
            raise InputError(f"nodes: coordinates must have shape ({len(ids)}, 2 or 3), got {xyz.shape}")
        if not np.all(np.isfinite(xyz)):
            raise InputError("nodes: coordinates contain NaN or infinite values")
        if xyz.shape[1] == 2:
            xyz = np.column_stack([xyz, np.zeros(len(xyz))])
        for i, x in zip(ids, xyz):
            i = int(i)
            if i in self.nodes or not -2**63 <= i < 2**63:  # ids are 64-bit integers where nodes are tabled
                raise InputError(f"node {i} defined twice" if i in self.nodes else f"node id {i}: out of range (|id| < 2**63)")
            self.nodes[i] = (float(x[0]), float(x[1]), float(x[2]))

    def support(self, dofs: Sequence[str]) -> None:
        """Fix dofs (they are removed from the model).

        Parameters
        ----------
        dofs : str or sequence of str
            Dof label(s) ``"node:dir"``; :meth:`build` checks that each is used by an element.
        """
        self.supports.extend(canonical(d) for d in ([dofs] if isinstance(dofs, str) else dofs))

    def support_node(self, nodes: Sequence[Node]) -> None:
        """Fix every dof that exists at the given nodes.

        Parameters
        ----------
        nodes : sequence of int or str
            Node numbers, or names of nodes that springs and masses use (``"A2"``);
            :meth:`build` checks that each is used by an element.

        Raises
        ------
        InputError
            A node that is neither an integer nor a valid node name.
        """
        self.support_nodes.extend(node_id(n, "support node") for n in nodes)

    # ------------------------------------------------------------------ elements
    def _add(self, type_, labels, props, where, **kw) -> None:
        n = len(labels)
        if n == 0:
            return
        required, optional = PROPS[type_]
        full = dict(optional)
        full.update({k: v for k, v in props.items() if v is not None})
        missing = [k for k in required if k not in full]
        if missing:
            raise InputError(f"{where}: {type_} needs {', '.join(missing)}")
        per = {k: per_element(v, n, f"{where}: {k}") for k, v in full.items()}
        self.groups.append(ElementGroup(type_, per, labels, where=[where if n == 1 else f"{where} [{i}]" for i in range(n)], **kw))

    def spring(self, dofs: Sequence[str], k, where: str = "spring") -> None:
        """Spring of stiffness ``k`` to ground (one dof) or between two dofs.

        Parameters
        ----------
        dofs : str or sequence of str
            One dof label (spring to ground) or two (spring between them).
        k : float or str
            Stiffness (N/m, or N·m/rad on rotations), or the name of a declared parameter.
        where : str, default ``"spring"``
            Name of the element in messages.

        Raises
        ------
        InputError
            Not one or two dofs; invalid labels; ``k`` missing.
        """
        dofs = canonical_all([dofs] if isinstance(dofs, str) else dofs, where)
        if len(dofs) not in (1, 2):
            raise InputError(f"{where}: a spring takes one dof (to ground) or two, got {len(dofs)}")
        self._add("spring", [list(dofs)], {"k": k}, where)

    def springs(self, dofs, k, where: str = "springs") -> None:
        """Vectorised springs: ``dofs`` is (n_el, 2) or (n_el, 1) labels.

        Parameters
        ----------
        dofs : sequence of sequences of str, shape ``(n_el, 1)`` or ``(n_el, 2)``
            One row of dof labels per spring.
        k : float, str or sequence
            Stiffness (N/m): a number, parameter name, or a sequence of either with one entry per element.
        where : str, default ``"springs"``
            Name of the elements in messages.
        """
        labels = [list(canonical_all(row, where)) for row in dofs]
        self._add("spring", labels, {"k": k}, where)

    def mass(self, dofs: Sequence[str], m, where: str = "mass") -> None:
        """Lumped mass ``m`` on each of the given dofs.

        Parameters
        ----------
        dofs : str or sequence of str
            Dof label(s) carrying the mass.
        m : float or str
            Mass (kg; a rotary inertia, kg·m², on rotation dofs), or a parameter name.
        where : str, default ``"mass"``
            Name of the element in messages.
        """
        dofs = canonical_all([dofs] if isinstance(dofs, str) else dofs, where)
        self._add("mass", [list(dofs)], {"m": m}, where)

    def _node_pairs(self, nodes, where):
        try:
            arr = np.asarray(nodes)
        except (TypeError, ValueError):  # ragged nesting
            arr = np.empty(0)
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise InputError(f"{where}: nodes must be a pair [a, b] (or an array of pairs), got {nodes!r}")
        if arr.dtype.kind in "USO":
            named = [v for v in arr.ravel().tolist() if isinstance(v, str) and not _is_integer_text(v)]
            if named:
                raise InputError(f"{where}: node {named[0]!r} is not an integer; line elements join [[node]] ids, which "
                                 "are integers (named nodes such as 'A2' are for springs, masses and matrix models)")
        if arr.dtype.kind not in "iuf" or (arr.dtype.kind == "f" and not np.all(np.isfinite(arr) & (arr == np.round(arr)))):
            raise InputError(f"{where}: node ids must be integers, got {nodes!r}")
        arr = arr.astype(np.int64)
        same = np.flatnonzero(arr[:, 0] == arr[:, 1])
        if same.size:
            raise InputError(f"{where}: element joins node {arr[same[0], 0]} to itself")
        return arr

    def _line(self, type_, nodes, props, where, dirs, **kw):
        pairs = self._node_pairs(nodes, where)
        labels = [[dof(a, d) for d in dirs] + [dof(b, d) for d in dirs] for a, b in pairs]
        self._add(type_, labels, props, where, nodes=pairs, **kw)

    def rod(self, nodes, E, A, rho, dim: int = 3, mass: str = "consistent", where: str = "rod") -> None:
        """Truss member(s) between node pairs; ``dim`` 2 (x, y) or 3 (x, y, z).

        Parameters
        ----------
        nodes : (int, int) or array_like of shape ``(n_el, 2)``
            End nodes of each member.
        E, A, rho : float, str or sequence
            Young's modulus, cross-section area and density, each a number, parameter name, or a
            sequence of either with one entry per element.
        dim : int, default 3
            2 (dofs x, y) or 3 (dofs x, y, z).
        mass : str, default ``"consistent"``
            ``"consistent"`` or ``"lumped"`` mass matrix.
        where : str, default ``"rod"``
            Name of the element(s) in messages.

        Raises
        ------
        InputError
            A bad ``dim`` or ``mass``; node pairs that are not integer pairs or join a node to
            itself; a missing property, or the wrong number of per-element values.
        """
        if dim not in (2, 3):
            raise InputError(f"{where}: dim must be 2 or 3, got {dim!r}")
        dirs = ("x", "y") if dim == 2 else ("x", "y", "z")
        self._line("rod", nodes, {"E": E, "A": A, "rho": rho}, where, dirs, mass=mass_kind(mass, where), dim=dim)

    def beam2d(self, nodes, E, A, I, rho, mass: str = "consistent", where: str = "beam2d") -> None:
        """Euler-Bernoulli beam(s) in the x-y plane (dofs x, y, rz).

        Parameters
        ----------
        nodes : (int, int) or array_like of shape ``(n_el, 2)``
            End nodes of each beam.
        E, A, I, rho : float, str or sequence
            Young's modulus, area, second moment of area and density, each a number, parameter
            name, or a sequence of either with one entry per element.
        mass : str, default ``"consistent"``
            ``"consistent"`` or ``"lumped"``.
        where : str, default ``"beam2d"``
            Name of the element(s) in messages.

        Raises
        ------
        InputError
            As :meth:`rod`.
        """
        self._line("beam2d", nodes, {"E": E, "A": A, "I": I, "rho": rho}, where, NODE_DIRS["beam2d"], mass=mass_kind(mass, where))

    def beam2d_terms(self, nodes, EA_l, k12, k6, k2, rho, A, mass: str = "consistent", where: str = "beam2d_terms") -> None:
        """Beam2d with the Appendix's independent stiffness terms EA/l, 12EI/l^3, 6EI/l^2, 2EI/l.

        Parameters
        ----------
        nodes : (int, int) or array_like of shape ``(n_el, 2)``
            End nodes of each beam.
        EA_l, k12, k6, k2 : float, str or sequence
            The stiffness terms EA/l, 12EI/l³, 6EI/l², 2EI/l, each a number, parameter name, or a
            sequence of either with one entry per element.
        rho, A : float, str or sequence
            Density and area, for the mass matrix as :meth:`beam2d`.
        mass : str, default ``"consistent"``
            ``"consistent"`` or ``"lumped"``.
        where : str, default ``"beam2d_terms"``
            Name of the element(s) in messages.

        Raises
        ------
        InputError
            As :meth:`rod`.
        """
        props = {"EA_l": EA_l, "k12": k12, "k6": k6, "k2": k2, "rho": rho, "A": A}
        self._line("beam2d_terms", nodes, props, where, NODE_DIRS["beam2d"], mass=mass_kind(mass, where))

    def frame3d(self, nodes, E, G, A, Iy, Iz, J, rho, orientation, mass: str = "consistent", where: str = "frame3d",
                **options) -> None:
        """12-dof space frame member(s); ``orientation`` lies in the local x-y plane.

        Parameters
        ----------
        nodes : (int, int) or array_like of shape ``(n_el, 2)``
            End nodes of each member.
        E, G, A, Iy, Iz, J, rho : float, str or sequence
            Young's and shear moduli, area, second moments of area about local y and z,
            torsion constant and density, each a number, parameter name, or a sequence of either
            with one entry per element.
        orientation : array_like, shape ``(3,)`` or ``(n_el, 3)``
            A vector in each member's local x-y plane (global components), finite.
        mass : str, default ``"consistent"``
            ``"consistent"`` or ``"lumped"``.
        where : str, default ``"frame3d"``
            Name of the element(s) in messages.
        **options
            ``offsets``, array_like of shape ``(2, 3)`` or ``(n_el, 2, 3)``: rigid end offsets
            [o_a, o_b] (global components), the member runs between x_a + o_a and x_b + o_b, joined
            rigidly to its nodes (exact, :mod:`femupdate.structure.links`); ``torsion_mass``, bool
            (default True): include the torsional inertia rho (Iy + Iz), False leaves the twist
            massless (Nastran's CBAR).

        Raises
        ------
        InputError
            A missing or malformed ``orientation`` or ``offsets``, an unknown option, and as :meth:`rod`.
        """
        unknown = sorted(set(options) - {"offsets", "torsion_mass"})
        if unknown:
            raise InputError(f"{where}: unknown option(s) {', '.join(unknown)} of frame3d (offsets, torsion_mass)")
        props = {"E": E, "G": G, "A": A, "Iy": Iy, "Iz": Iz, "J": J, "rho": rho}
        self._frame("frame3d", nodes, props, orientation, mass, where, options.get("offsets"),
                    torsion_mass=bool(options.get("torsion_mass", True)))

    def frame3d_terms(self, nodes, EA_l, GJ_l, rho, A, Ip, orientation, *, mass: str = "consistent",
                      where: str = "frame3d_terms", offsets=None, **bending) -> None:
        """Space frame with the Appendix's independent stiffness terms as properties.

        Give ``k12, k6, k2`` (shared by both bending planes: Iy = Iz, the Appendix's five
        unknowns EA/l, 12EI/l^3, 6EI/l^2, GJ/l, 2EI/l) or the per-plane ``*_y`` and ``*_z``.

        Parameters
        ----------
        nodes : (int, int) or array_like of shape ``(n_el, 2)``
            End nodes of each member.
        EA_l, GJ_l : float, str or sequence
            Axial and torsional stiffness terms EA/l and GJ/l.
        rho, A, Ip : float, str or sequence
            Density, area and polar moment of area, for the mass matrix.
        orientation : array_like, shape ``(3,)`` or ``(n_el, 3)``
            A vector in each member's local x-y plane.
        mass : str, default ``"consistent"``
            ``"consistent"`` or ``"lumped"``.
        where : str, default ``"frame3d_terms"``
            Name of the element(s) in messages.
        offsets : array_like, shape ``(2, 3)`` or ``(n_el, 2, 3)``, optional
            Rigid end offsets, as :meth:`frame3d`.
        **bending : float, str or sequence
            The bending terms, as the model file names them: ``k12``, ``k6``, ``k2`` (12EI/l³,
            6EI/l², 2EI/l) shared by both planes, or per bending plane ``k12_y``, ``k6_y``,
            ``k2_y``, ``k12_z``, ``k6_z``, ``k2_z``.

        Every property is a number, parameter name, or a sequence of either with one entry per element.

        Raises
        ------
        InputError
            A bending term given both shared and per plane, or neither, or a property that is not
            a bending term; and as :meth:`frame3d`.
        """
        props = {"EA_l": EA_l, "GJ_l": GJ_l, "rho": rho, "A": A, "Ip": Ip}
        names = [b + side for b in BENDING for side in ("", "_y", "_z")]
        unknown = sorted(set(bending) - set(names))
        if unknown:
            raise InputError(f"{where}: unknown property {unknown[0]!r} of frame3d_terms (its bending terms: "
                             f"{', '.join(names)})")
        given = {n: bending.get(n) for n in names}
        for b in BENDING:
            both, y, z = given[b], given[b + "_y"], given[b + "_z"]
            if both is not None and (y is not None or z is not None):
                raise InputError(f"{where}: give either {b} (both planes) or {b}_y and {b}_z, not both")
            if both is None and (y is None or z is None):
                raise InputError(f"{where}: frame3d_terms needs {b} (both planes) or both {b}_y and {b}_z")
            props[b + "_y"] = both if both is not None else y
            props[b + "_z"] = both if both is not None else z
        self._frame("frame3d_terms", nodes, props, orientation, mass, where, offsets)

    def _frame(self, type_, nodes, props, orientation, mass, where, offsets=None, **kw):
        if orientation is None:
            raise InputError(f"{where}: {type_} needs an orientation vector [vx, vy, vz] in its local x-y plane")
        pairs = self._node_pairs(nodes, where)
        o = np.asarray(orientation, dtype=float)
        if o.shape == (3,):
            o = np.broadcast_to(o, (len(pairs), 3))
        if o.shape != (len(pairs), 3) or not np.all(np.isfinite(o)):
            raise InputError(f"{where}: orientation must be three finite numbers (or one triple per element)")
        dirs = NODE_DIRS[type_]
        labels = [[dof(a, d) for d in dirs] + [dof(b, d) for d in dirs] for a, b in pairs]
        data = None
        if offsets is not None:
            off = np.asarray(offsets, dtype=float)
            off = np.broadcast_to(off, (len(pairs), 2, 3)) if off.shape == (2, 3) else off
            if off.shape != (len(pairs), 2, 3) or not np.all(np.isfinite(off)):
                raise InputError(f"{where}: offsets must be [[ax, ay, az], [bx, by, bz]] (or one such pair per element), finite")
            data = off.reshape(len(pairs), 6).copy()
        self._add(type_, labels, props, where, nodes=pairs, mass=mass_kind(mass, where), orientation=np.array(o), data=data, **kw)

    def shell(self, nodes, E, nu, t, rho, mass: str = "consistent", drill: float = 0.1, where: str = "shell") -> None:
        """Flat shell element(s): MITC4 quadrilaterals (4 nodes) or MITC3 triangles (3 nodes).

        Dofs ``x, y, z, rx, ry, rz`` at each node; formulation, drilling treatment and dof order in
        :mod:`femupdate.elements_3d.shells`.  K = E t K_membrane + E t³ K_bending + E t K_shear
        + E t K_drill, M = rho t M_translation + rho t³ M_rotation.

        Parameters
        ----------
        nodes : sequence of int or array_like, shape ``(n_el, 3)`` or ``(n_el, 4)``
            Corner node ids of each element, counter-clockwise about its normal.
        E, rho : float, str or sequence
            Young's modulus (Pa) and density (kg/m³): a number, a parameter name, or one per element.
        nu : float or sequence of float
            Poisson's ratio, -1 < nu < 0.5 (a number: it enters non-linearly).
        t : float, str or sequence
            Thickness (m): a number, a parameter name (the model then holds the non-linear terms
            E t³ of bending and ρ t³ of rotary inertia: :mod:`femupdate.coefficients`), or one per
            element.
        mass : {"consistent", "lumped"}, default "consistent"
            Mass matrix.
        drill : float, default 0.1
            Drilling penalty factor (times G t).
        where : str, default ``"shell"``
            Name of the element(s) in messages.

        Raises
        ------
        InputError
            Not 3 or 4 integer node ids per element, a node listed twice, nu outside (-1, 0.5) or a
            parameter, a bad ``drill`` or ``mass``; degenerate or inverted elements
            are refused by :meth:`build`.
        """
        from .continuum import add_shell

        add_shell(self, nodes, E, nu, t, rho, mass, drill, where)

    def solid(self, nodes, E, nu, rho, mass: str = "consistent", where: str = "solid") -> None:
        """Solid element(s): 8-node hexahedra (incompatible modes, QM6), 4- or 10-node tetrahedra.

        Dofs ``x, y, z`` at each node (no rotations); node orders and formulation in
        :mod:`femupdate.elements_3d.solids`.  K = E K_E, M = rho M_rho.

        Parameters
        ----------
        nodes : sequence of int or array_like, shape ``(n_el, 4 | 8 | 10)``
            Node ids of each element (4: tet4, 8: hex8, 10: tet10).
        E, rho : float, str or sequence
            Young's modulus (Pa) and density (kg/m³): a number, a parameter name, or one per element.
        nu : float or sequence of float
            Poisson's ratio, -1 < nu < 0.5.
        mass : {"consistent", "lumped"}, default "consistent"
            Mass matrix.
        where : str, default ``"solid"``
            Name of the element(s) in messages.

        Raises
        ------
        InputError
            As :meth:`shell`.
        """
        from .continuum import add_solid

        add_solid(self, nodes, E, nu, rho, mass, where)

    # ------------------------------------------------------------------ dict / TOML form
    @classmethod
    def from_dict(cls, data: Mapping, source: str = "model") -> Structure:
        """Structure from the parsed TOML model file (schema in docs/file-formats.md).

        Parameters
        ----------
        data : mapping
            The parsed model file (``[model]``, ``[parameters.NAME]``, ``[[node]]``,
            ``[[element]]``, ``[[support]]`` tables).
        source : str, default ``"model"``
            Name of the source (e.g. the file path), used in messages.

        Returns
        -------
        Structure

        Raises
        ------
        InputError
            A malformed table, as described in the messages.
        """
        return structure_from_dict(cls, data, source)

    @classmethod
    def from_mesh(cls, file, sets: Mapping | None = None, support=None, *, format: str | None = None,
                  name: str | None = None, units: str | None = None, check_units: bool = True) -> Structure:
        """Structure from a mesh file: Gmsh ``.msh`` (through meshio), Abaqus ``.inp``, Nastran bulk data.

        Nodes keep the file's ids (dof labels ``"id:dir"``) and coordinates; each element set with a
        section (the deck's, or ``sets``) becomes a shell, solid or frame group (:mod:`femupdate.mesh`);
        a deck's springs, point masses and exact constraints (Nastran CELAS, CONM2, RBE2; Abaqus
        ``*KINEMATIC COUPLING``, ``*MPC``) come with it.
        Declare the parameters that ``sets`` names with :meth:`parameter` before :meth:`build`.

        Parameters
        ----------
        file : str or os.PathLike
            The mesh file.
        sets : mapping, optional
            Element set name -> properties ``E``, ``nu``, ``rho``, ``t`` (shells), ``mass``,
            ``drill``, and for beams ``G``, ``A``, ``Iy``, ``Iz``, ``J``; each a number or (``E``,
            ``rho``, ``t`` and the beam properties) a parameter name; overrides the deck's.
        support : sequence of mapping, optional
            Each ``{"set": NODE_SET}`` or ``{"nodes": [ids]}``, optionally ``"dofs": ["x", ...]``
            (directions; default every dof of the nodes).
        format : {"gmsh", "nastran", "abaqus"}, optional
            Default by suffix.
        name : str, optional
            Name of the structure (default: the file's stem).
        units : {"m-kg-s", "mm-t-s"}, optional
            The mesh's consistent unit system (parameter units; frequencies in Hz with either).
            Undeclared: SI unit names, values not checked.
        check_units : bool
            Refuse moduli and densities (numbers, and parameter values at :meth:`build`) that
            contradict the declared ``units``; ``False`` skips the check.

        Raises
        ------
        InputError
            As :func:`femupdate.mesh.read_mesh` and the ``[mesh]`` table (docs/file-formats.md).
        """
        from pathlib import Path

        from ..mesh import read_mesh
        from ..mesh.model import add_mesh

        s = cls(name if name is not None else Path(file).stem)
        add_mesh(s, read_mesh(file, format), sets, support, str(file), units, check_units)
        return s

    # ------------------------------------------------------------------ assembly
    def build(self) -> Model:
        """Assemble the affine sparse model (no dense global matrix is formed).

        Dofs are the labels used by the elements, sorted by node and direction, minus the
        supported ones.

        Returns
        -------
        Model
            K0, M0 from the numeric properties, one dK/dM per declared parameter; the nodes
            used by elements.

        Raises
        ------
        InputError
            No elements; a support dof or node used by no element; every dof supported; an
            undefined node; an undeclared parameter name; a non-finite or non-positive property;
            a term that multiplies two parameters (the model would not be affine); and as
            :class:`~femupdate.model.Model`.
        """
        from .assembly import assemble

        return assemble(self)

__all__ = ["Structure"]
