"""The 2-D x-periodic cell 0 <= x < L, 0 < z < H."""
