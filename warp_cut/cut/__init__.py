"""The three-stage cut (paper section 2.3), laid out by stage: the ``cutter`` drives it after
each step (in the step, or in a worker: ``driver``, ``background``, ``cut_worker``); ``contact``
finds where the blade meets the skin, ``curve`` is Stage 2 (the incision curve), ``sweep`` Stage 1
(what one event's blade swept), ``remesh`` Stage 3 (the re-mesh in a ``chart`` of the rest
surface), ``wound`` what the cut leaves. Every edit goes through ``topology`` (the one place
topology changes); ``classes`` names the node and spring classes, ``tolerances`` the tolerances."""
