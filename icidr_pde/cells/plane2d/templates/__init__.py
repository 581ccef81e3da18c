"""Loop-kernel templates: module sources combined with a law by
:func:`icidr_pde.rheology.codegen.compose` (never imported directly)."""
