"""Triangle meshes: the skin patch generator (``patch``), skin-like surfaces with the analytic
charts they sample (``surfaces``, ``charts``, ``triangulate``), triangle geometry
(``geometry``) and the mesh invariants and quality checks (``checks``)."""
