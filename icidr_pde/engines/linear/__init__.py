"""The linear solvers of the Newton systems and their preconditioners."""
