"""The report's section on test points placed on the mesh (a result's ``test_points``)."""

from __future__ import annotations

from .document import Cell, Figure, Section, Table, Text, num

MAX_ROWS = 60


def test_points_section(result: dict, model, segments) -> Section | None:
    """Where each test node lies on the mesh: a figure and the map (``test_points`` of the result)."""
    tp = result.get("test_points")
    if not tp:
        return None
    points = tp.get("points") or []
    sec = Section("test-points", "Test points on the mesh")
    inside = sum(p.get("kind") == "element" for p in points)
    sec.add(Text(f"{len(points)} test node(s) placed on the mesh by their coordinates ({tp.get('method')}; tolerance "
                 f"{num(tp.get('tolerance'))}, largest distance {num(tp.get('largest_distance'), 3)}): {inside} inside "
                 "an element, their measured motion the element's shape functions times its nodes' motion; the "
                 "others on one mesh node. Their measured dofs are labelled as the column 'dofs' says."))
    if model is not None and getattr(model, "nodes", None):
        from ..plot.testpoints import test_points_figure

        sec.add(Figure(test_points_figure(model.nodes, segments, points),
                       "The mesh (grey) and the test points (red); a red line joins a point off the mesh to where "
                       "it was placed."))
    t = Table("test points", ["test node", "placed", "mesh nodes (weights)", "element", "distance", "dofs"])
    for p in points[:MAX_ROWS]:
        nodes = ", ".join(f"{n} ({num(w, 3)})" for n, w in zip(p.get("mesh_nodes", []), p.get("weights", [])))
        t.rows.append([Cell(str(p.get("test_node"))), Cell(str(p.get("kind"))), Cell(nodes), Cell(str(p.get("element") or "")),
                       Cell(num(p.get("distance"), 3)), Cell(", ".join(sorted((p.get("dofs") or {}).values())))])
    sec.add(t)
    if len(points) > MAX_ROWS:
        sec.add(Text(f"The first {MAX_ROWS} of {len(points)} test points are listed (all are in the JSON result).", "note"))
    return sec
