"""Mode shapes drawn on the model's geometry (femupdate.plot.shapes, issue 18): the deformed
wireframe is the nodes moved by the scaled translations, a measured shape is fitted to the
model's by least squares, planar structures are drawn in their plane and others in 3-D, and a
model without coordinates falls back to the shape against its dofs, saying so."""

from __future__ import annotations

import numpy as np
import pytest

import femupdate as fu
from femupdate.examples import portal_frame, truss_model_toml, two_dof
from femupdate.fullfield import structure_segments
from femupdate.io.model_file import read_toml
from femupdate.plot.shapes import NO_GEOMETRY, mode_shape_axes, needs_3d, shape_geometry
from femupdate.structure import Structure

matplotlib = pytest.importorskip("matplotlib")
from matplotlib.figure import Figure  # noqa: E402


@pytest.fixture(scope="module")
def truss(tmp_path_factory):
    path = tmp_path_factory.mktemp("truss") / "truss.toml"
    path.write_text(truss_model_toml())
    s = Structure.from_dict(read_toml(path))
    return s, s.build()


def _members(ax, label):
    """The polylines of the members drawn under ``label`` (one collection per wireframe)."""
    (coll,) = [c for c in ax.collections if c.get_label() == label]
    return coll.get_segments()


def test_segments_from_the_structure_include_supported_members(truss):
    s, model = truss
    coupled = shape_geometry(model)
    full = shape_geometry(model, structure_segments(s))
    ids = full.node_ids
    pairs = {tuple(sorted((ids[a], ids[b]))) for a, b in full.segments}
    assert pairs == {tuple(p) for p in structure_segments(s).tolist()}
    assert len(coupled.segments) < len(full.segments)  # members to the supports are not in K's couplings


def test_deformed_wireframe_is_the_nodes_moved_by_the_scaled_translations(truss):
    s, model = truss
    modes = fu.model_modes(model)
    phi = modes.shapes[:, 0]
    ax = mode_shape_axes(model, phi, segments=structure_segments(s), scale=0.5, ax=Figure().add_subplot())
    assert ax.name != "3d"  # a plane truss is drawn in its plane
    geom = shape_geometry(model, structure_segments(s))
    moved = {tuple(np.round(xy, 12)) for seg in _members(ax, "model") for xy in seg}
    for k, nd in enumerate(geom.node_ids):
        u = [phi[model.dofs.index(f"{nd}:{d}")] if f"{nd}:{d}" in model.dofs else 0.0 for d in "xy"]
        assert tuple(np.round(geom.xyz[k, :2] + 0.5 * np.array(u), 12)) in moved
    assert "displacements × 0.5" in ax.get_title()


def test_a_measured_shape_is_fitted_to_the_model_shape_by_least_squares(truss):
    s, model = truss
    phi = fu.model_modes(model).shapes[:, 1]
    measured = {d: -3.0 * phi[model.dofs.index(d)] for d in model.dofs if d.startswith("10")}  # scaled, sign flipped
    ax = mode_shape_axes(model, phi, measured, segments=structure_segments(s), scale=1.0, ax=Figure().add_subplot())
    (marks,) = [ln for ln in ax.get_lines() if ln.get_label() == "test"]
    geom = shape_geometry(model)
    pos = {nd: k for k, nd in enumerate(geom.node_ids)}
    want = np.array([geom.xyz[pos[nd], :2] + [phi[model.dofs.index(f"{nd}:x")], phi[model.dofs.index(f"{nd}:y")]]
                     for nd in sorted({int(d.split(":")[0]) for d in measured})])
    got = np.column_stack(marks.get_data())
    np.testing.assert_allclose(got[np.lexsort(got.T[::-1])], want[np.lexsort(want.T[::-1])], atol=1e-12)


def test_space_frames_are_drawn_in_3d_and_planar_frames_in_their_plane():
    frame = portal_frame()
    assert not needs_3d(frame, fu.model_modes(frame, n_modes=2).shapes[:, 0])
    s = Structure("space")
    s.parameter("E", 2.1e11)
    for i, xyz in enumerate([(0, 0, 0), (0, 0, 3), (2, 0, 3), (2, 1, 3)], start=1):
        s.node(i, xyz)
    for a, b in ((1, 2), (2, 3), (3, 4)):
        s.frame3d([a, b], E="E", G=8e10, A=1e-3, Iy=2e-6, Iz=2e-6, J=4e-6, rho=7850.0,
                  orientation=(0, 0, 1) if (a, b) != (1, 2) else (1, 0, 0))
    s.support_node([1])
    model = s.build()
    phi = fu.model_modes(model, n_modes=2).shapes[:, 0]
    assert needs_3d(model, phi)
    fig = Figure()
    ax = mode_shape_axes(model, phi, segments=structure_segments(s), ax=fig.add_subplot(projection="3d"))
    assert ax.name == "3d" and ax.get_zlabel() == "z [m]"


def test_a_lumped_model_without_coordinates_is_drawn_against_its_dofs():
    model = two_dof()
    phi = fu.model_modes(model).shapes[:, 1]
    assert shape_geometry(model) is None
    ax = mode_shape_axes(model, phi, {"2:x": 1.0}, title="mode 2")
    assert NO_GEOMETRY in ax.get_title() and "mode 2" in ax.get_title()
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == "model"]
    np.testing.assert_allclose(line.get_ydata(), phi)
    (marks,) = [ln for ln in ax.get_lines() if ln.get_label() == "test"]
    np.testing.assert_allclose(marks.get_ydata(), [phi[1]])  # the one measured value, fitted to the model's


def test_bad_arguments_are_refused_by_name():
    model = two_dof()
    with pytest.raises(ValueError, match="give a model shape, a test shape or both"):
        mode_shape_axes(model)
    with pytest.raises(ValueError, match="shape has 3 values; the model has 2 dofs"):
        mode_shape_axes(model, np.ones(3))
    with pytest.raises(ValueError, match="projection must be"):
        mode_shape_axes(model, np.ones(2), projection="4d")


def test_a_bent_member_follows_the_beam_deflection_its_end_rotations_give():
    """A cantilever under a tip load P bends as v(x) = P x² (3L − x) / (6 EI), a cubic: the member
    drawn from its end translations and rotations (v(L) = PL³/3EI, θ(L) = PL²/2EI) is that curve."""
    from femupdate.plot.shapes import member_points

    L, P, EI = 2.0, 1.0, 3.0
    tip, slope = P * L**3 / (3 * EI), P * L**2 / (2 * EI)
    pts = member_points([0, 0, 0], [L, 0, 0], [0, 0, 0], [0, tip, 0], [0, 0, 0], [0, 0, slope], scale=1.0, n=11)
    x = np.linspace(0, L, 11)
    np.testing.assert_allclose(pts[:, 0], x, atol=1e-15)  # no axial motion
    np.testing.assert_allclose(pts[:, 1], P * x**2 * (3 * L - x) / (6 * EI), rtol=1e-12, atol=1e-15)
    # the same member along z bending in x-z (rotation about y: du_x/dz = θ_y)
    pts = member_points([0, 0, 0], [0, 0, L], [0, 0, 0], [tip, 0, 0], [0, 0, 0], [0, slope, 0], n=11)
    np.testing.assert_allclose(pts[:, 0], P * x**2 * (3 * L - x) / (6 * EI), rtol=1e-12, atol=1e-15)
    # without rotations: a straight member between the moved ends
    np.testing.assert_allclose(member_points([0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 1, 0], scale=0.5),
                               [[0, 0, 0], [1, 0.5, 0]])
