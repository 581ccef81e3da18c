"""heap.keep_freed_arrays: a grid-sized array freed and allocated again is not faulted in again.

The kernel's own count of minor page faults is the truth: 64 MiB newly mapped cost one fault per
4 kB page when written (16384), taken from the heap again none. The block is malloc's own, as a
compiled kernel's or a library's work array is (numpy asks for huge pages for its arrays, which
fault once per 2 MB but are zeroed all the same)."""

import subprocess
import sys

import pytest

CHILD = """
import ctypes, resource, sys
from icidr_pde.heap import keep_freed_arrays
libc = ctypes.CDLL(None)
libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)
if sys.argv[1] == "keep":
    assert keep_freed_arrays()
size = 64 << 20
faults = []
for _ in range(4):  # the first allocation faults in any case; the next reuse it or not
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    block = libc.malloc(size)
    ctypes.memset(block, 1, size)
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
    libc.free(block)
print(*faults)
"""

glibc = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc only")
PAGES = (64 << 20) // 4096


def _faults(mode: str, **env) -> list[int]:
    import os

    environ = {k: v for k, v in os.environ.items()
               if k not in ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")}
    out = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True, check=True,
                         env={**environ, **env})
    return [int(f) for f in out.stdout.split()]


@glibc
def test_an_array_freed_is_reused_without_page_faults():
    plain, kept = _faults("plain"), _faults("keep")
    assert all(f > PAGES // 2 for f in plain), plain  # malloc's default: a new mapping every time
    assert kept[0] > PAGES // 2, kept  # the first one is faulted in
    assert all(f < PAGES // 20 for f in kept[1:]), kept


@glibc
def test_the_users_own_malloc_setting_is_kept():
    out = subprocess.run([sys.executable, "-c", "from icidr_pde.heap import keep_freed_arrays as k; print(k())"],
                         capture_output=True, text=True, check=True,
                         env={**__import__("os").environ, "MALLOC_MMAP_THRESHOLD_": "131072"})
    assert out.stdout.strip() == "False"
