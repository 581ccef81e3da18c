"""Checks of user input, shared by every public entry point (API, CLI, PDE classes, laws).

Each check returns the value converted to its canonical type or raises
:class:`ParameterError` (a ``ValueError``) whose message names the parameter, states
the valid range and shows the value received, e.g.
``` `t_end` must be a finite number > 0; got inf ```.
Strings are not numbers here (``'10'`` is refused, not parsed): parsing belongs to the
command line, whose argparse types call the same checks.
"""

from __future__ import annotations

import math
import numbers
import os

__all__ = ["ParameterError", "real", "integer", "choice", "shown", "memory_bytes", "format_bytes"]


class ParameterError(ValueError):
    """A public parameter has a wrong type or lies outside its valid range."""


def shown(value) -> str:
    """The received value as the message shows it: repr, plus the type unless obvious."""
    if isinstance(value, bool) or value is None:
        return repr(value)
    if isinstance(value, numbers.Real):
        return f"{float(value):g}" if isinstance(value, float) else repr(value)
    return f"{value!r} (a {type(value).__name__})"


def _range_text(low, high, low_open, high_open) -> str:
    if low is not None and high is not None:
        return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f"{'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"{'<' if high_open else '<='} {high:g}"
    return ""


def real(name: str, value, low: float | None = None, high: float | None = None, *,
         low_open: bool = True, high_open: bool = True, what: str = "a finite number") -> float:
    """`value` as a float: a finite real number (not a bool or a string) in the given range."""
    wanted = " ".join(s for s in (what, _range_text(low, high, low_open, high_open)) if s)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    if low is not None and (x <= low if low_open else x < low):
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    if high is not None and (x >= high if high_open else x > high):
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    return x


def integer(name: str, value, low: int | None = None, high: int | None = None, *, hint: str = "") -> int:
    """`value` as an int: an integer (or an integral float) in [low, high]."""
    wanted = " ".join(s for s in ("an integer", _range_text(low, high, False, False)) if s) + hint
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(float(value)) \
        and float(value) == int(value)
    if not ok:
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    n = int(value)
    if (low is not None and n < low) or (high is not None and n > high):
        raise ParameterError(f"`{name}` must be {wanted}; got {shown(value)}")
    return n


def choice(name: str, value, choices) -> str:
    """`value` if it is one of `choices` (compared as given: names are case-sensitive)."""
    options = list(choices)
    try:
        if value in options:
            return value
    except TypeError:  # unhashable
        pass
    raise ParameterError(f"`{name}` must be one of {sorted(options)}; got {shown(value)}")


def memory_bytes() -> int | None:
    """Physical memory of this machine in bytes (None where the OS does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def format_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"
