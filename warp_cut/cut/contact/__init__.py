"""Where the blade meets the skin: the tool's axis crossing the deformed skin (``surface``),
carried into the rest shape (``material_point``), and the blade's contact with an incision
(``contact``)."""
