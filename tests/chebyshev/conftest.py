"""Shared set-up of the Chebyshev tests: one BLAS thread (the dense LU of the
Chebyshev Jacobian is many times slower with OpenBLAS threads on a busy machine)."""

import warnings

import pytest

from icidr_pde.studies import limit_blas_threads

limit_blas_threads(1)


@pytest.fixture(autouse=True)
def _quiet_numba():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*is faster on contiguous arrays.*")
        yield
