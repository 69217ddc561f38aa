"""What the cut leaves: the residual links across the wound (``links``), the pieces it frees
(``islands``), what it is judged by (``measures``, ``width_curve``) and the straight reference
slit of the fracture-mechanics check (``reference_slit``)."""
