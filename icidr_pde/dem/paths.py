"""Committed DEM results (read through the package) and default output locations.

Committed summaries live in ``data/dem`` of the repository and ship with the
package; :func:`committed` finds them from any working directory.  Commands
never write there by default: outputs go to the directory given by
``--out`` (default: the current directory), and the run cache to the user
cache (:func:`icidr_pde.dem.cache.default_cache_dir`).
"""

from __future__ import annotations

from pathlib import Path

from ..datafiles import data_dir


def committed_dir() -> Path:
    return data_dir() / "dem"


def committed(name: str) -> Path:
    """Path of a committed DEM summary, e.g. ``committed('steady.json')``; raises
    FileNotFoundError naming the file when it is not shipped."""
    path = committed_dir() / name
    if not path.exists():
        raise FileNotFoundError(f"committed DEM result {name!r} not found in {committed_dir()}")
    return path
