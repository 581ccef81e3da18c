"""The registry of figures (:data:`FIGURES`): a name, a one-line caption, the paper's caption and
a function drawing it from a :class:`~.runs.RunCache`; :func:`register_figure` adds one."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from .runs import at_resolution

__all__ = ["FIGURES", "FigureSpec", "register_figure"]


@dataclass(frozen=True)
class FigureSpec:
    """A figure: `draw(runs) -> (matplotlib Figure, numbers)`; `runs` is a :class:`RunCache`."""

    name: str
    caption: str
    paper: str
    draw: Callable
    dims: str = "1d"
    source: str = "computed"  # or a committed data file
    command: str = field(default="")

    def heading(self, numbers: dict, draft: bool = False) -> str:
        """The one-line caption, its ``{fields}`` filled from the figure's `numbers` (counts
        that come from the data), at the resolution drawn (:func:`at_resolution`)."""
        return at_resolution(self.caption.format_map(_Unknown(numbers)), draft)


class _Unknown(dict):
    """Numbers for a caption; a field a figure's (older) numbers lack reads "?"."""

    def __missing__(self, key):
        return "?"


FIGURES: dict[str, FigureSpec] = {}


def register_figure(name: str, caption: str, paper: str, *, dims: str = "1d", source: str = "computed"):
    """Decorator adding a drawing function to :data:`FIGURES` under `name`."""

    def decorator(draw):
        FIGURES[name] = FigureSpec(name, caption, paper, draw, dims, source,
                                   command=f"icidr-pde figures --only {name}")
        return draw

    return decorator
