"""Stage 1, what one event's blade swept, in the rest shape: the piece of curve it cuts
(``piece``), the region re-meshed round it (``region``), the slit's band (``slit_band``, taken
from the model in ``event_band``) and the strip beside an opening cut off with it (``beside``)."""
