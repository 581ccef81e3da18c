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
import stat

import numpy as np

__all__ = ["ParameterError", "real", "integer", "choice", "shown", "memory_bytes", "format_bytes",
           "MEMORY_ENV", "FIELDS", "ATOL_FRACTION", "check_atol", "nonfinite_rates",
           "output_path", "input_file"]


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


def _integer_wanted(low, high) -> str:
    return " ".join(s for s in ("an integer", _range_text(low, high, False, False)) if s)


def integer(name: str, value, low: int | None = None, high: int | None = None, *, hint: str = "") -> int:
    """`value` as an int: an integer (or an integral float) in [low, high]."""
    wanted = _integer_wanted(low, high) + hint
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


#: environment variable overriding the memory :func:`memory_bytes` reports (bytes; for tests)
MEMORY_ENV = "ICIDR_PDE_MEMORY"


def memory_bytes() -> int | None:
    """Memory available to a run in bytes: $ICIDR_PDE_MEMORY if set, else the kernel's
    MemAvailable (/proc/meminfo), else the physical memory (None where the OS says neither)."""
    override = os.environ.get(MEMORY_ENV)
    if override:
        wanted = f"`${MEMORY_ENV}` must be a finite number of bytes > 0; got {override!r}"
        try:
            amount = float(override)
        except ValueError:
            raise ParameterError(wanted) from None
        if not (math.isfinite(amount) and amount > 0):  # 'inf', '1e400' parse as inf: no int of it
            raise ParameterError(wanted)
        return int(amount)
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
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


#: the fields of the shear cell's state, in its order
FIELDS = ("phi", "u", "w")
#: atol above this fraction of the largest initial field magnitude controls nothing: measured,
#: iCIDR shear and sine, fd N = 201: atol = 1e-3 keeps max|w| within 7 %, 1e-2 lets the steps
#: carry phi out of (0, phi_c) (a failure that is not the law's)
ATOL_FRACTION = 1e-3


def check_atol(atol: float, data, asked: bool = True) -> float:
    """atol between the round-off of the field scale max|data| of the initial state (a smaller one
    asks the error test to control round-off: the integrator fails, or crawls, as if the law had
    blown up; checked where the atol was `asked` for, not a preset's on absurd data, whose rates
    say what is wrong) and :data:`ATOL_FRACTION` of it (a larger one controls no error)."""
    scale = float(np.max(np.abs(data))) if np.size(data) else 1.0
    low, high = (np.finfo(float).eps * scale if asked else 0.0), ATOL_FRACTION * scale
    if not low <= atol <= high:
        raise ParameterError(f"`atol` must be in [{low:.3g}, {high:g}] (from the round-off of the initial fields' "
                             f"largest magnitude {scale:g} to {ATOL_FRACTION:g} of it: beyond, it controls no "
                             f"error); got {shown(atol)}")
    return atol


def invalid_state(y, check_fields, fields) -> str | None:
    """Why the state vector `y` of an engine is invalid: non-finite, or what check_fields(fields(y))
    says (phi outside its range); None if it is valid."""
    if not np.all(np.isfinite(y)):
        return "state became non-finite"
    return check_fields(fields(y))


def nonfinite_rates(rates, t: float = 0.0) -> str | None:
    """Why the rates (fields first: phi, u, w) at time t make the run meaningless, or None."""
    rates = np.asarray(rates)
    bad = ~np.isfinite(rates.reshape(rates.shape[0], -1))
    if not bad.any():
        return None
    where = ", ".join(f"d{name}/dt at {int(bad[k].sum())} of {bad[k].size} nodes"
                      for k, name in enumerate(FIELDS[:rates.shape[0]]) if bad[k].any())
    return f"right-hand side not finite at t = {t:g} ({where})"


def output_path(name: str, value):
    """`value` as a file path for an output (a str or os.PathLike), or None; a TypeError
    naming the parameter for anything else (a number, bytes)."""
    if value is None or isinstance(value, str) or (isinstance(value, os.PathLike)
                                                  and isinstance(os.fspath(value), str)):
        return value
    raise TypeError(f"`{name}` must be a file path (a str or os.PathLike) or None; got {shown(value)}")


def input_file(name: str, path) -> str:
    """`path` if it names a regular file (a symbolic link to one included); ParameterError
    naming the parameter and saying what it is otherwise: missing, a directory, a FIFO (reading
    one waits for a writer), a device or a socket are not files of data."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise ParameterError(f"`{name}` must be an existing file; {str(path)!r} does not exist") from None
    except OSError as err:
        raise ParameterError(f"`{name}` must be a readable file; {str(path)!r} cannot be examined "
                             f"({err.strerror})") from None
    if stat.S_ISREG(mode):
        try:
            with open(path, "rb"):
                pass
        except OSError as err:
            raise ParameterError(f"`{name}` must be a readable file; {str(path)!r} cannot be read "
                                 f"({err.strerror})") from None
        return path
    what = ("a directory" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode) else
            "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else
            "a socket" if stat.S_ISSOCK(mode) else "not a regular file")
    raise ParameterError(f"`{name}` must be a regular file; {str(path)!r} is {what}")
