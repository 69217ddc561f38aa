"""Judging a cut against the stroke that made it, for tests, the fuzz driver and users checking
their own meshes: every invariant after every edit (``validity``), a stroke cut as a user
would drive it (``stroke_check``), and how well the cut followed it (``stroke_quality``:
coverage, lip deviation, slivers, split incisions, holes). For several strokes: incisions of
several strokes (``incision_sets``, with ``lowered_entry`` for a tool lowered onto the skin),
any disk-like mesh as a Surface (``mesh_surface``), and the state the strokes left, judged from
the model's arrays (``cut_judge``: the cut's triangles at rest and now, wound against the
surface or folded, holes, pieces, a freed island)."""
