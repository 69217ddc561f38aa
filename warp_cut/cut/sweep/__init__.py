"""Stage 1, what one event's blade swept, in the rest shape: the piece of curve it cuts
(``piece``), the region re-meshed round it (``region``), the slit's band (``slit_band``, taken
from the model in ``event_band``), the strip beside an opening cut off with it (``beside``),
and which rest points lie in the tissue or in an opening (``tissue_at_rest``)."""
