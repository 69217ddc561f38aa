"""warp_cut/sim/statics.py: static equilibrium held in the sheet's plane (``planar``).

Compared against closed forms: a node joined to four pinned corners of a square by springs
longer than their span (compressed) has two kinds of equilibrium, the square's centre in its
plane and, out of it, the height where every spring has its rest length.
"""

import numpy as np

from warp_cut import TissueModel
from warp_cut.sim.statics import static_equilibrium

HALF = 0.01  # half the square's side [m]
REST = 0.02  # rest length of the four springs [m], longer than the corner distance


def compressed_star(z0: float) -> TissueModel:
    """Four pinned corners of a square in z = 0 and a free node near its centre at height z0,
    joined by four springs of rest length ``REST``."""
    corners = [[-HALF, -HALF, 0.0], [HALF, -HALF, 0.0], [HALF, HALF, 0.0], [-HALF, HALF, 0.0]]
    points = np.array(corners + [[0.002, -0.001, z0]])
    springs = np.array([[0, 4], [1, 4], [2, 4], [3, 4]])
    return TissueModel.from_arrays(points, springs, 1e-3, pinned=[0, 1, 2, 3], stiffness=100.0,
                                   rest_lengths=np.full(4, REST))


def test_a_planar_solve_holds_the_plane_where_a_free_one_buckles_out_of_it():
    z0 = 1e-5
    planar = static_equilibrium(compressed_star(z0), planar=True, max_newton=60)
    assert planar.converged
    assert planar.positions[4, 2] == z0  # held
    np.testing.assert_allclose(planar.positions[4, :2], [0.0, 0.0], atol=1e-9)  # the centre
    free = static_equilibrium(compressed_star(z0), max_newton=200)
    assert free.converged
    height = np.sqrt(REST ** 2 - 2 * HALF ** 2)  # every spring at its rest length: no force
    np.testing.assert_allclose(free.positions[4], [0.0, 0.0, height], rtol=1e-6, atol=1e-9)
