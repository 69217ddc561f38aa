"""Where the blade meets the skin: the tool's axis crossing the deformed skin (``surface``),
carried into the rest shape (``material_point``), the blade's contact with an incision
(``contact``) and rest points in the tissue or in an opening (``tissue_at_rest``)."""
