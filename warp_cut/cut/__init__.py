"""The three-stage cut (paper section 2.3): the ``cutter`` drives it after each step; Stage 1's
edit goes through ``topology`` (the one place topology changes), Stage 2 is ``incision`` and
``bezier``, Stage 3 is ``remesh``; ``classes`` names the node and spring classes, and
``width_curve`` measures the opening wound."""
