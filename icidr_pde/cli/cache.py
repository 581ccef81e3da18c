"""``icidr-pde cache {info,clear}``: where the kernel cache is, what it holds, and emptying it
(:mod:`icidr_pde.kernel_cache`)."""

from __future__ import annotations

import json

from .argtypes import subcommand

__all__ = ["add_parser", "cmd"]


def add_parser(subparsers):
    """Add ``cache info`` and ``cache clear`` to the ``icidr-pde`` command."""
    p = subparsers.add_parser(
        "cache", help="the kernel cache: where it is, its size, clear it",
        description="The kernel cache holds the kernels generated and compiled from the laws (numba modules, "
                    "native libraries), in $NUMBA_CACHE_DIR/icidr_pde_kernels, else "
                    "$XDG_CACHE_HOME/icidr_pde/kernels, else ~/.cache/icidr_pde/kernels. Kernels of older code "
                    "versions are removed when a new version writes its first kernel.")
    sub = p.add_subparsers(dest="cache_command", required=True)
    i = subcommand(sub, "info", _info, help="folder, size, number of kernels, how many belong to this code version")
    i.add_argument("--json", action="store_true", help="print the figures as JSON")
    c = subcommand(sub, "clear", _clear, help="remove every kernel (they are rebuilt when next needed); files "
                                              "a running process is writing are left, and runs go on")
    c.add_argument("--stale", action="store_true", help="remove only the kernels of other code versions")
    return p


def _size(n: int) -> str:
    for unit in ("B", "kB", "MB"):
        if n < 1000:
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} GB"


def _info(args) -> int:
    from .. import kernel_cache

    out = kernel_cache.info()
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    where = out["folder"] or "(none)"
    print(f"kernel cache: {where} (from {out['setting']})")
    if out["refused"]:
        print(f"  not used: {out['refused']} (runs use a private temporary folder)")
    print(f"  size: {_size(out['bytes'])} in {out['files']} files")
    print(f"  kernels: {out['kernels']}: {out['current']} of this code version ({out['version']}), "
          f"{out['stale']} stale ({_size(out['stale_bytes'])})")
    return 0


def _clear(args) -> int:
    from .. import kernel_cache

    path, count, size = kernel_cache.clear(stale_only=args.stale)
    what = ("stale " if args.stale else "") + ("file" if count == 1 else "files")
    print(f"removed {count} {what} ({_size(size)}) from {path}")
    return 0


def cmd(args) -> int:
    """Run ``cache info`` or ``cache clear``, as parsed."""
    return args.func(args)
