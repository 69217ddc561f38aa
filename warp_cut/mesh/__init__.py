"""Triangle meshes: the skin patch generator (``patch``), triangle geometry (``geometry``) and
the mesh invariants and quality checks (``checks``)."""
