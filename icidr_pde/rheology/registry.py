"""The registry of laws: :data:`RHEOLOGIES`, name -> law class.

A law class with a ``name`` registers itself (:meth:`~.base.Rheology.__init_subclass__`: one
class in one file); a law defined at run time (a law file, :func:`~.cidr.define_cidr_law`,
:func:`~.direct.define_direct_law`, :func:`~.direct.define_rheology`) is registered by
:func:`register_law` under a name of its own, checked by :func:`check_law_name`: a law file
may not shadow a built-in law. The look-up by name or file is :func:`~.lookup.get_rheology`.
"""

from __future__ import annotations

import re

__all__ = ["RHEOLOGIES", "check_law_name", "register_law"]

#: name -> Rheology subclass; filled by the subclasses themselves and by :func:`register_law`
RHEOLOGIES: dict[str, type] = {}


def check_law_name(name) -> None:
    """A law defined at run time needs a name of its own: a built-in law's name is refused."""
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_\-]*", name):
        raise ValueError(f"`name` must start with a letter and contain letters, digits, '_' or '-'; got {name!r}")
    taken = RHEOLOGIES.get(name)
    if taken is not None and not taken.defined_at_run_time:
        builtin = sorted(k for k, v in RHEOLOGIES.items() if not v.defined_at_run_time)
        raise ValueError(f"`name` {name!r} is a built-in law's; a law defined at run time needs a name of its "
                         f"own (built-in: {', '.join(builtin)})")


def register_law(name, cls, register: bool = True) -> type:
    """`cls`, named `name` and marked as defined at run time; in :data:`RHEOLOGIES` if `register`."""
    check_law_name(name)
    cls.name = name
    cls.defined_at_run_time = True
    if register:
        RHEOLOGIES[name] = cls
    return cls
