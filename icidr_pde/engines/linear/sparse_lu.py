"""Sparse LU of the Newton matrix on the scheme's pattern: CVODE's SuperLU_MT, scipy's SuperLU."""

from __future__ import annotations

from .base import JacobianForm, LinearSolver, Memory

__all__ = ["SuperLUMT", "ScipySuperLU", "SPARSE_LU_BYTES"]

#: SuperLU_MT's factors ('sparse'), per unknown beyond the scheme's estimate: their fill-in, taken
#: from the peak memory of 2-D runs (docs/scaling.md, the memory section)
SPARSE_LU_BYTES = 23_500.0 / 3


class SuperLUMT(LinearSolver):
    """SuperLU_MT on the fixed pattern, analytic values."""

    name = "SuperLU_MT"
    modes = ("sparse",)
    methods = ("CVODE",)
    preference = 70
    form = JacobianForm("sparse")
    petsc = ("preonly", "lu")

    def memory(self, n, method, mode, thin=False):
        return Memory(SPARSE_LU_BYTES * n, "SuperLU_MT's LU factors", repr(mode))

    def cvode_options(self, problem, rtol, atol):
        import numpy as np

        values = pattern_values(problem.jacobian.jac, problem.jacobian.sparsity)

        def jacfn(t, y, yp, JJ):
            JJ[:] = values(t, np.array(y))

        return dict(linsolver="sparse", sparsity=problem.jacobian.sparsity, jacfn=jacfn)


class ScipySuperLU(LinearSolver):
    """scipy's BDF and Radau on a sparse Jacobian (analytic or colored difference quotients): SuperLU."""

    name = "SuperLU"
    modes = ("analytic", "sparse-fd", "colored-fd")
    methods = ("BDF", "Radau")
    engine = "scipy"
    preference = 10
    form = JacobianForm("sparse")

    def offered(self, mode, structure):
        return structure.sparse


def pattern_values(jac, pattern):
    """values(t, y): the sparse jac(t, y) in the CSC order of `pattern` (zeros where it has none)."""
    import numpy as np
    from scipy import sparse

    P = sparse.csc_matrix(pattern)
    P.sort_indices()
    keys = np.repeat(np.arange(P.shape[1], dtype=np.int64), np.diff(P.indptr)) * P.shape[0] + P.indices

    def values(t, y):
        J = sparse.coo_matrix(jac(t, y))
        pos = np.searchsorted(keys, J.col.astype(np.int64) * J.shape[0] + J.row)
        if np.any(pos >= keys.size) or np.any(keys[np.minimum(pos, keys.size - 1)] != J.col.astype(np.int64) * J.shape[0] + J.row):
            raise ValueError("the Jacobian has entries outside its declared sparsity pattern")
        out = np.zeros(keys.size)
        np.add.at(out, pos, J.data)
        return out

    return values
