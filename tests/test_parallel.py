"""The serial path of the studies' runs (icidr_pde.studies.parallel.run_cases with jobs=1).

Truth: the caller's own state before the call. A serial sweep runs each case as a worker
would (one BLAS thread, warnings off: the numbers of the process pool and of dask tasks)
and leaves the caller's BLAS threads and warning filters as they were.
"""

from __future__ import annotations

import importlib
import warnings

import pytest

from icidr_pde.studies.parallel import blas_threads, limit_blas_threads, run_cases

ft = importlib.import_module("icidr_pde.studies.failure_time")


@pytest.fixture
def two_blas_threads():
    """The caller runs OpenBLAS on 2 threads (restored to what it was after the test)."""
    before = blas_threads()
    if not before:
        pytest.skip("no OpenBLAS library is loaded in this process")
    limit_blas_threads(2)
    if set(blas_threads().values()) != {2}:
        limit_blas_threads(min(before.values()))
        pytest.skip(f"OpenBLAS cannot run 2 threads in this process (it runs {before})")
    yield
    limit_blas_threads(min(before.values()))


def test_a_serial_sweep_restores_the_callers_blas_threads_and_warnings(two_blas_threads, monkeypatch):
    real = ft.failure_time
    seen = []

    def recording(**kwargs):
        seen.append((blas_threads(), warnings.filters[0][0]))
        return real(**kwargs)

    monkeypatch.setattr(ft, "failure_time", recording)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        filters = list(warnings.filters)
        out = ft.sweep([21, 25], ("fd",), jobs=1, progress=False, t_end=0.01)
        assert warnings.filters == filters
    assert sorted(out["fd"]) == [21, 25] and len(seen) == 2
    for threads, action in seen:          # each run as a worker runs
        assert set(threads.values()) == {1} and action == "ignore"
    assert set(blas_threads().values()) == {2}  # and the caller's threads are back


def test_a_run_that_raises_restores_the_callers_state(two_blas_threads):
    def fails(case):
        raise KeyError(case)

    filters = list(warnings.filters)
    with pytest.raises(KeyError):
        list(run_cases(fails, [1], 1, False))
    assert set(blas_threads().values()) == {2} and warnings.filters == filters


def test_a_serial_study_left_in_the_callers_state_sees_it(two_blas_threads):
    assert list(run_cases(lambda case: set(blas_threads().values()), [1], 1, False, init_here=False)) == [{2}]


@pytest.mark.parametrize("jobs", [0, -1, 1.5, "2", True])
def test_bad_jobs_are_refused_naming_the_range(jobs):
    with pytest.raises(ValueError, match=r"`jobs` must be an integer in \[1, \d+\]; got"):
        list(run_cases(str, [1], jobs, False))
