import os
import shutil
import tempfile

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

# The suite's own kernel cache, never the user's: set here, before any test module imports
# icidr_pde (or numba, which reads NUMBA_CACHE_DIR once), inherited by pytest-xdist's workers and
# by every subprocess a test starts. Removed by the process that created it.
if not os.environ.get("ICIDR_PDE_TEST_KERNEL_CACHE"):
    os.environ["ICIDR_PDE_TEST_KERNEL_CACHE"] = tempfile.mkdtemp(prefix="icidr-pde-test-kernels-")
    os.environ["ICIDR_PDE_TEST_KERNEL_CACHE_OWNER"] = str(os.getpid())
os.environ["NUMBA_CACHE_DIR"] = os.environ["ICIDR_PDE_TEST_KERNEL_CACHE"]


@pytest.fixture(scope="session", autouse=True)
def test_kernel_cache():
    """The folder holding the suite's kernel cache (NUMBA_CACHE_DIR of every test)."""
    return os.environ["ICIDR_PDE_TEST_KERNEL_CACHE"]


def pytest_unconfigure(config):
    if os.environ.get("ICIDR_PDE_TEST_KERNEL_CACHE_OWNER") == str(os.getpid()):
        shutil.rmtree(os.environ["ICIDR_PDE_TEST_KERNEL_CACHE"], ignore_errors=True)
