"""The mesh checker and the triangle geometry this package uses, imported in this one place:
``check_mesh`` and its helpers live in ``warp_cut.mesh_checks`` now and may move to
``warp_cut.mesh.checks``; only the import below then changes."""

from ..mesh_checks import check_mesh, edges_of, triangle_min_angles

__all__ = ["check_mesh", "edges_of", "triangle_min_angles"]
