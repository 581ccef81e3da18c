"""The 1-D shear cell 0 < z < H."""
