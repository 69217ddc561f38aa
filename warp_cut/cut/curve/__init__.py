"""Stage 2, the incision curve: the blade's path carried into the rest shape, its stations and
lips (``incision``) and the Bézier curve fitted through it (``bezier``, paper Eq. 5-8)."""
