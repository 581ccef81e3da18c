"""The cells: each a package of its own (``shear1d``, ``plane2d``)."""
