"""Stage 3, the re-mesh in a chart of the rest surface: the region less the band laid out
(``layout``), filled at a guaranteed smallest angle (``fill``, ``coarsen``), checked and written
through the TopologyEditor (``cut_piece``); a finished strip made Delaunay (``flips``)."""
