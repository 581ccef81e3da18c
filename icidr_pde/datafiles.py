"""Where the committed results (the repository's ``data/``) are, installed or not.

A wheel ships ``data/`` inside the package as ``icidr_pde/data`` (pyproject
``package-dir``); a source tree or an editable install reads ``<repo>/data``.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["data_dir"]

_PACKAGE = Path(__file__).resolve().parent


def data_dir() -> Path:
    """The directory holding benchmarks/, dem/, reference/, ... (installed copy first)."""
    installed = _PACKAGE / "data"
    return installed if installed.is_dir() else _PACKAGE.parent / "data"
