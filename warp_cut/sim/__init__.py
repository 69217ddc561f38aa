"""The simulated tissue: Model (``model``, ``material``, ``slots``), its device mirror
(``device_model``), State, Control (``control``: the tool), the stable step (``stability``),
spring stiffness from the material (``stiffness``) and the tool's collision tests
(``collision``, ``ccd``)."""
