"""The ffmpeg that movies run: the binary of the ``imageio-ffmpeg`` wheel (a dependency), so that
no system package is needed, for this package's movies and for matplotlib's.

This package's own movies (:mod:`icidr_pde.movies`) hand their frames to imageio-ffmpeg, which
finds its binary itself. matplotlib's movie writer (``matplotlib.animation.FFMpegWriter``), which
py-pde's ``pde.visualization.movie`` and ``PlotTracker(movie=...)`` use, runs the program named by
the rcParam ``animation.ffmpeg_path`` (default ``"ffmpeg"``, looked up on PATH) and knows nothing
of the wheel: without a system ffmpeg, py-pde answers "FFMpegWriter is not available".
:func:`point_matplotlib` sets that rcParam to the wheel's binary, but only when it names no program
that exists: a system ffmpeg, or a path the user set, is kept.

``import icidr_pde`` calls it when matplotlib is loaded (at once if it already is, else as soon as
it is imported: :func:`when_matplotlib_loads`), so that a py-pde movie of this package's PDEs works
as it would with a system ffmpeg. It is done then, and not by importing matplotlib when
``icidr_pde`` or its py-pde classes are imported, because a run that draws nothing imports no
matplotlib (``tests/test_startup.py``); and not only in :mod:`icidr_pde.movies`, because a user of
py-pde's movies never imports that.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import shutil
import sys

__all__ = ["ffmpeg_exe", "point_matplotlib", "when_matplotlib_loads"]


def ffmpeg_exe() -> str | None:
    """Path of the ffmpeg binary that imageio-ffmpeg runs (its wheel's, else one on PATH), or None."""
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return None


def point_matplotlib() -> str | None:
    """Point matplotlib's ``animation.ffmpeg_path`` at :func:`ffmpeg_exe` if it names no program
    that exists (``shutil.which``, as matplotlib's ``FFMpegWriter.isAvailable`` looks); return the
    ffmpeg matplotlib runs now (None if there is none)."""
    import matplotlib

    current = str(matplotlib.rcParams["animation.ffmpeg_path"])
    if shutil.which(current) is not None:
        return current
    exe = ffmpeg_exe()
    if exe is None:
        return None
    matplotlib.rcParams["animation.ffmpeg_path"] = exe
    return exe


class _AfterMatplotlib(importlib.abc.MetaPathFinder):
    """Finds nothing itself: when ``matplotlib`` is about to be imported, it takes the spec the
    other finders give and makes its loader call :func:`point_matplotlib` once the module has run;
    it then leaves ``sys.meta_path``."""

    def find_spec(self, name, path=None, target=None):
        if name != "matplotlib":
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        exec_module = spec.loader.exec_module

        def exec_then_point(module):
            exec_module(module)
            _point_quietly()

        spec.loader.exec_module = exec_then_point  # this spec's loader only (a finder makes one a spec)
        return spec


def _point_quietly() -> None:
    # an ffmpeg that cannot be found must not make `import matplotlib` fail: matplotlib then says
    # "FFMpegWriter is not available" when a movie is asked for, as it would without this package
    try:
        point_matplotlib()
    except Exception:  # noqa: BLE001
        pass


def when_matplotlib_loads() -> None:
    """Call :func:`point_matplotlib` now if matplotlib is loaded, else when it is imported."""
    if "matplotlib" in sys.modules:
        _point_quietly()
    elif not any(isinstance(finder, _AfterMatplotlib) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterMatplotlib())
