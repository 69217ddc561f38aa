"""The cut's tolerances, named, with their units, in one place.

Lengths are given as fractions of the cut's station spacing s (about the mesh's spring length,
``CutSettings.spacing``) unless they say otherwise; angles in degrees. Every decision of the
three stages is taken in the rest (material) shape with these, so none of them depends on where
the tool has pushed the skin.
"""

from __future__ import annotations

MIN_ANGLE_DEG = 20.0
"""Smallest angle a triangle the cut makes may have in the rest shape [deg] (checked in 3D)."""

REFINE_ANGLE_DEG = 22.0
"""The angle the refinement aims for in the region's flat chart [deg]: a little above
``MIN_ANGLE_DEG``, so that lifting the chart onto a curved rest surface keeps every angle at
least ``MIN_ANGLE_DEG``."""

CLEARANCE = 0.3
"""Least distance [x s] between a lip line and a tissue node that is kept beside it: nodes nearer
the curve than lip offset + CLEARANCE x s are cleared with the swept band, so no triangle
between a lip and a node beside it is thin (a 20 deg triangle on a base s is 0.18 s high)."""

MIN_ADVANCE = 0.25
"""Least advance of the blade along the rest curve [x s] that extends an incision (less waits
for the next event: a re-mesh for nothing)."""

EXIT_ADVANCE = 0.02
"""Least advance [x s] of the blade's last crossing before it left the skin past the incision's
path that still carries the path on to it (the incision then reaches where the blade left;
``MIN_ADVANCE`` holds only for the events while the blade is in)."""

FIRST_STATION = 0.65
"""Distance [x s] of a slit's first station from its start (or from the border of an opening it
went on from). The wedge between a slit's end and its nearest lip pair is bridged by one long
edge a side, which shortens the crack as the sheet sees it: a short first wedge keeps a
prestressed sheet's opening within 7 % of Griffith's (``tests/test_fracture.py``), a whole
spacing left 11 %."""

STATION_TURN_DEG = 45.0
"""Most the curve may turn [deg] from one lip station to the next: round a sharper bend a
station comes sooner than a spacing on (``Incision.next_station_after``). The band runs
straight between stations, and a spacing's chord round a sharp corner would cut off the tissue
inside it (at a zigzag's corner: the hole it left was the fuzz's commonest). An arc
turns 45 deg a spacing at a radius of 1.3 s: arcs of 5 spacings and more keep a station a
spacing (30 deg drew lips together round bends the fill then refused more often)."""

STATION_GAP = 0.75
"""Least distance [x s] between two lip stations along the curve."""

LINK_TAKER_MASS = 0.2
"""A node taking a carried link (``carry_links``) weighs at least this fraction of the median
mass of the candidates [-]: a bundle of links on a near-massless node made by the re-mesh
crushes its triangles and shortens the stable step."""

LINK_REACH = 0.5
"""A separated spring's link goes to a lip pair within this [x s] along the curve of where the
spring crossed, else it waits for the next station: stations are at most a spacing apart, so no later
one can lie nearer, and the links depend on the curve alone, not on when the events fell."""

LAST_STATION = 0.5
"""Least distance [x s] from the newest lip station to the slit's tip."""

ROUND_ANGLE_DEG = 75.0
"""A corner of the re-meshed region sharper than this [deg] (the region's triangles at one of
its border nodes) takes in that node's whole fan: the fill then has room for good triangles."""

VOID_REACH = 0.35
"""A crossing of the blade farther than this [x s] from every live triangle lies over an
opening (an earlier wound): it is not carried into the rest shape, the incision waits."""

REGION_MARGIN = 0.5
"""Triangles within lip offset + clearance + REGION_MARGIN x s of the curve are re-meshed."""

CORNER_CUT = 0.5
"""Width [x s] of the cut across a sharp corner of tissue at a node on a border (an earlier
wound's edge between the slit and that wound): its tip goes with the band
(``layout.corner_cut``)."""

MAX_GROWTH = 4
"""Times a region may grow (a fixed edge the refinement had to split, a sharp corner) before its
fill is accepted as it is."""


SNAP = 0.3
"""A lip line meeting a border (an earlier wound, the tissue's edge) within this [x s] of a border
node meets it at that node (the paper's node matching: no tiny triangle beside it)."""

MERGE = 0.1
"""A new point of the slit's outline (a lip, where a lip line meets a border) within this [x s]
of a node next to it on the outline is left out: the outline goes straight on to the node."""

CROSSING_MERGE = 0.2
"""A point where a lip line meets a border within this [x s] of the new point next to it on the
outline is left out (``layout._merge_crossings``): a lip line over the corner of an earlier
wound's border crossed it twice a hundredth of a spacing apart, and made a triangle that small."""

LIP_MATCH = 0.3
"""A new lip within this [x s] of an earlier lip of its own side is that lip (node matching
round a bend, ``cut_piece._match_bend_lips``): on the inside of a sharp bend the lip lines of the
legs before and after it meet, and lips a sliver apart leave triangles that small."""

MATCH = 1e-4
"""A vertex of the region's new outline (GEOS's result) within this [x s] of a node or of a band
point is that node or point: the polygon operations return their input vertices only to
rounding, and a corner cut off a band moves them by more than the rounding grid."""

COARSEN = 0.25
"""A point the refinement inserted with an edge shorter than this [x s] is taken out again where
the triangles round it can be re-made at ``REFINE_ANGLE_DEG`` without it (``coarsen``): round a
thin slit's tip the refinement's splits cascade down to the slit's width, and small triangles
are crushed by small relative motions of their nodes (slivers as the skin lies)."""

MIN_EDGE = 0.01
"""Shortest edge the refinement may make [x s]."""

OLD_END_CLEARANCE = 0.02
"""Least distance [x s] of a new lip from the end of the slit cut before (past its newest lip
pair): a lip nearer, or in that opening (the refitted curve can run a little to one side of
the curve the old end was cut along), moves out across the curve (``remesh``)."""

SCRAP_AREA = 0.25
"""A piece of tissue an event leaves apart from the rest with a rest area below this [x s^2]
(about half a regular triangle of side s) is a scrap, removed whatever the settings say: a fleck
the cut trimmed off, not a piece of skin (``islands.scraps_from``)."""

SCRAP_TRIANGLES = 6
"""A piece is searched as a scrap up to this many triangles (a larger one is not a scrap)."""

FLAP_AREA = 0.5
"""A piece of tissue held to the rest by one edge only is a flap, removed within the edit that
leaves it, with the flaps its removal leaves in turn while their rest area in all stays below this
[x s^2] (``islands.flaps_from``, ``FreedPieces.remove_flaps``): a membrane's springs resist no turn
about that edge, and the foundation, acting on the small area of its nodes against their damping,
turns it back over minutes, not the fraction of a second the skin takes to settle. Without the
bound a long thin wedge between a zigzag's legs went whole."""

FLAP_TRIANGLES = 32
"""A flap, and such a chain of them, holds at most this many triangles."""

NECK_REACH = 4.0
"""Longest run of curve [x the edge clearance, lip offset + ``CLEARANCE`` s] over the tissue but
nowhere clear of its borders, between two openings, that the blade cuts through as a neck
(``tissue_at_rest.necks``): a neck narrower than twice the edge clearance crossed at 30 deg or
more to its sides. A longer one runs beside a border (a recut wandering off its wound's line),
and no strip is cut there (``beside``)."""

BESIDE_RUN = 0.5
"""Least length [x s] of curve running beside an opening (``beside``: a border across the curve
nearer than the edge clearance) whose strip of tissue the blade cuts off. Shorter runs are where
a stroke meets or leaves a wound at a steep angle; the band's ends join those as before. Half a
spacing: with the clearance of a 1 mm tool on a 2 mm grid (0.85 mm) a crossing under about 40
degrees gets its strips. At one spacing the runs a stroke crossing a wound 20-35 degrees off its
line makes from the wound to its end, or a thick tool's (its clearance is wider) anywhere,
were neither clear of the border nor a strip, and stayed uncut (fuzz case 2579376181 stroke 3:
0.48 covered); at a quarter spacing steep crossings cut strips their band's ends had joined
(coverage down to 0.09 on one stroke, three times the small triangles)."""

TOOL_HOLD = 1.5
"""Nodes nearer the tool's axis than TOOL_HOLD tool radii are held by the tool (pushed onto its
cylinder) [x tool radius]: the map of the tissue round the blade leaves them out
(``contact.Contact.material``, ``remesh.placement``)."""

MAP_WIDTH = 1.5
"""Width of the Gaussian weights of the tissue's map round a point: the tool's radius plus
MAP_WIDTH x s."""
