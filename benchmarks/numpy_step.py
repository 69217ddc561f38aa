"""The semi-implicit step of warp_cut in vectorised numpy: the baseline of the throughput bench.

Same physics as ``SemiImplicitSolver`` with gravity and the tool: spring forces, gravity,
implicit damping, pinned nodes, the paper's cylinder test and push-out with its reaction.
float32 like the device arrays; the scatter of spring forces uses ``np.bincount`` (the
fastest vectorised scatter-add numpy has; ``np.add.at`` is several times slower).
"""

from __future__ import annotations

import numpy as np


class NumpySemiImplicit:
    """One substep of h [s] on host arrays; ``step(tool)`` with tool = (p0, p1, radius) or None."""

    def __init__(self, model, gravity=(0.0, 0.0, -9.81)):
        f32 = np.float32
        self.x = model.points.astype(f32)
        self.v = np.zeros_like(self.x)
        self.i = model.springs[:, 0].astype(np.int64)
        self.j = model.springs[:, 1].astype(np.int64)
        self.rest = model.rest_lengths.astype(f32)
        self.k = model.stiffness.astype(f32)
        self.m = model.masses.astype(f32)[:, None]
        self.D = model.damping.astype(f32)[:, None]
        self.free = (~model.pinned)[:, None]
        self.g = np.asarray(gravity, f32)
        self.n = model.node_count
        self.tool_force = np.zeros(3)

    def step(self, h: float, tool=None) -> None:
        x, n = self.x, self.n
        d = x[self.j] - x[self.i]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        scale = np.where(length > 1e-12, self.k * (1 - self.rest / np.maximum(length, 1e-12)), 0)
        f = d * scale[:, None]
        F = np.empty_like(x)
        for c in range(3):
            F[:, c] = np.bincount(self.i, f[:, c], minlength=n) - np.bincount(self.j, f[:, c], minlength=n)
        F += self.m * self.g
        v = (self.m * self.v + h * F) / (self.m + h * self.D)
        v = np.where(self.free, v, 0)
        x_new = x + h * v
        if tool is not None:
            p0, p1, r = (np.asarray(tool[0], np.float32), np.asarray(tool[1], np.float32), tool[2])
            axis = p1 - p0
            L = float(np.linalg.norm(axis))
            if L > 0 and r > 0:
                a = axis / L
                s = (x_new - p0) @ a
                perp = (x_new - p0) - s[:, None] * a
                dist = np.sqrt(np.einsum("ij,ij->i", perp, perp))
                inside = (s >= 0) & (s <= L) & (dist < r) & self.free[:, 0]
                if inside.any():
                    idx = np.flatnonzero(inside)
                    nrm = perp[idx] / np.maximum(dist[idx], 1e-30)[:, None]
                    target = p0 + s[idx, None] * a + nrm * r
                    dx = target - x_new[idx]
                    x_new[idx] = target
                    v[idx] += dx / h
                    inertia = self.m[idx] + h * self.D[idx]
                    self.tool_force -= (dx * inertia).sum(axis=0) / (h * h)
        self.x, self.v = x_new, v
