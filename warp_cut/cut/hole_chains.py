"""The border chains of a hole a cut leaves (Stage 3's input): walked from the triangles the
edit removed, split where the border pinches and at the lips, and started at the slit's start.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .lip_slots import LipSlots

__all__ = ["hole_chains", "split_at_lips", "start_at_slit_start"]


def hole_chains(editor, removed_corners, open_chains=()) -> list[list[int]]:
    """Border chains of the hole left by removed triangles (their corners, winding order).

    A chain follows the directed edges a -> b of removed triangles that a surviving triangle
    still uses (it is the hole's border, oriented like the removed surface). Closed chains
    repeat their first node at the end. Edges on the tissue's outer border break chains.
    ``open_chains``: borders of holes an earlier event left open, joined in again.
    """
    active = editor.model.active
    nxt: dict[int, list[int]] = defaultdict(list)
    incoming: dict[int, int] = defaultdict(int)
    seen = set()
    edges = [(i, j) for a, b, c in removed_corners for i, j in ((a, b), (b, c), (c, a))]
    edges += [(i, j) for chain in open_chains for i, j in zip(chain[:-1], chain[1:])]
    for i, j in edges:
        if (i, j) in seen or not (active[i] and active[j]):
            continue
        if len(editor.triangles_with_edge(i, j)) == 1 and not _runs(editor, i, j):
            seen.add((i, j))
            nxt[i].append(j)
            incoming[j] += 1
    chains = []
    starts = [v for v in nxt if incoming[v] == 0]
    while True:
        if starts:
            v = starts.pop()
        else:
            remaining = [u for u, outs in nxt.items() if outs]
            if not remaining:
                break
            v = remaining[0]
        chain = [v]
        while nxt.get(v):
            v = nxt[v].pop()
            chain.append(v)
            if v == chain[0]:
                break
        if len(chain) > 1:
            chains.extend(_split_pinches(chain))
    return chains


def _split_pinches(chain: list[int]) -> list[list[int]]:
    """A border chain that passes a node twice (two lobes of a hole touching at a node) as
    simple chains: each lobe a closed loop of its own, and what is left."""
    closed = chain[0] == chain[-1]
    body = chain[:-1] if closed else list(chain)
    loops, stack, where = [], [], {}
    for v in body:
        if v in where:  # the lobe since the last visit is a loop of its own
            k = where[v]
            loop = stack[k:] + [v]
            for u in stack[k + 1:]:
                where.pop(u, None)
            del stack[k + 1:]
            if len(loop) > 3:
                loops.append(loop)
            continue
        where[v] = len(stack)
        stack.append(v)
    rest = stack + [stack[0]] if closed else stack
    return ([rest] if len(rest) > 1 else []) + loops


def _runs(editor, a, b) -> bool:
    """True if a live triangle already runs the edge a -> b (the hole must run it b -> a)."""
    corners = editor.model.triangle_table.column("corners")
    for t in editor.triangles_with_edge(a, b):
        c = corners[t]
        if any(c[k] == a and c[(k + 1) % 3] == b for k in range(3)):
            return True
    return False


def split_at_lips(chain, slots: LipSlots) -> list[list[int]]:
    """A border chain cut at the live lip nodes (and the start or end node) it passes: the
    hole touches the slit's border there, and each piece is filled against the lips between
    its two ends (a lip inside a piece would be paired with other lips across the slit). A
    piece that is one edge between two such nodes is the slit's border itself: dropped."""
    lips = set(slots.theta)
    cuts = [k for k in range(1, len(chain) - 1) if chain[k] in lips]
    if not cuts:
        return [chain]
    if chain[0] == chain[-1] and chain[0] not in lips:  # closed: begin at a lip
        body = chain[:-1]
        chain = body[cuts[0]:] + body[:cuts[0]] + [body[cuts[0]]]
        cuts = [k for k in range(1, len(chain) - 1) if chain[k] in lips]
    ends = [0] + cuts + [len(chain) - 1]
    pieces = [chain[a:b + 1] for a, b in zip(ends[:-1], ends[1:])]
    return [p for p in pieces if len(p) > 2 or not (p[0] in lips and p[-1] in lips)]


def start_at_slit_start(chain, incision, slots: LipSlots) -> list[int]:
    """A closed chain rotated to begin (and end) at the slit's start node, or the node nearest
    it (theta ~ 0); an open chain as it is."""
    if chain[0] != chain[-1]:
        return chain
    body = chain[:-1]
    total = 2.0 * incision.length
    if incision.start_node in body:
        k = body.index(incision.start_node)
    else:
        slots.projected(body)  # all at once
        k = int(np.argmin([min(slots.theta_of(v), total - slots.theta_of(v)) for v in body]))
    return body[k:] + body[:k] + [body[k]]
