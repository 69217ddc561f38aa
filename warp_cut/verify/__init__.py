"""Judging a cut against the stroke that made it, for tests, the fuzz driver and users checking
their own meshes: every invariant after every edit (``validity``), a stroke cut as a user
would drive it (``stroke_check``), and how well the cut followed it (``stroke_quality``:
coverage, lip deviation, slivers, split incisions, holes)."""
