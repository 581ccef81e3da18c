"""Build and load the native engine's shared library for a law: C generated once, compiled once.

The C text of a library is the law printed by :mod:`icidr_pde.rheology.ccode`, the
finite-volume and Chebyshev kernels printed from their numba templates
``cells/shear1d/templates/fd.py`` and ``cheb.py`` by :mod:`.translate` (the 1-D cell's library;
the 2-D cell's, of the law of plane flow, has the kernels of ``cells/plane2d/templates/plane2d.py``
instead: each cell's descriptor names its templates, :mod:`icidr_pde.cells`) (with
``kernel_support.c``), the cell's compiled problems (its folder's ``problem.c``, after ``problem.h``)
and the CVODE driver ``cvode_driver.c`` (with ``sundials_api.h``): one library a cell and law. It is compiled by gcc
(``$CC``) into the kernel cache (:mod:`icidr_pde.kernel_cache`)
and linked against the SUNDIALS libraries that scikit-sundae ships (``scikit_sundae.libs``,
found from the package's location without importing it; its LAPACK dense solver where
present, for Chebyshev, and its GMRES, SPGMR, for Chebyshev's Newton-Krylov option), then loaded
with ctypes.

A library's name is a hash of everything its text is generated from (the inputs of the
law's numba kernels, this package's sources, the template, the SUNDIALS library files and
index type, the compiler), looked up before any sympy work: a warm run imports neither
sympy nor scikit-sundae. The kernel cache checks a library against the hash of its bytes
before it is loaded; the C text goes to the compiler on its standard input (no C file is
written, none found in the cache is compiled). A law the C printer refuses leaves a ``.unsupported`` note
with the reason, so that later runs fall back at once. Any reason the engine cannot be
built is a :class:`NativeUnavailable` with a one-line message.
"""

from __future__ import annotations

import contextlib
import ctypes
import glob
import importlib.resources
import importlib.util
import inspect
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import threading
import time

__all__ = ["NativeUnavailable", "sundials", "library", "LIBRARY_FLAGS"]

LIBRARY_FLAGS = ("-O2", "-std=gnu99", "-fPIC", "-shared", "-ffp-contract=off", "-fvisibility=hidden")
_LIBRARIES: dict[str, ctypes.CDLL] = {}
_LOCK = threading.Lock()


class NativeUnavailable(RuntimeError):
    """The native engine cannot run this case here; the message says why (one line)."""


def _text(name: str) -> str:
    return importlib.resources.files(__package__).joinpath(name).read_text()


def _cell(kinematics):
    """The cell whose laws are evaluated in `kinematics`: its library's templates and
    definitions (:mod:`icidr_pde.cells`)."""
    from ..cells import cell_of

    return cell_of(kinematics)


def _scheme_templates(kinematics=None) -> tuple[str, ...]:
    """The numba templates of the schemes of `kinematics`' cell (fd and cheb, or fv2d; None: of
    every cell), the one source of each scheme's kernels (read by path: importing a scheme would
    import py-pde)."""
    from ..cells import cells

    chosen = cells().values() if kinematics is None else [_cell(kinematics)]
    return tuple(text for cell in chosen for text in cell.template_texts())


def _template(kinematics=None) -> str:
    """What the scheme kernels' C is made of (for the key): the templates and their printer."""
    return "\n".join([*_scheme_templates(kinematics), _text("translate.py"), _text("kernel_support.c")])


def _scheme_kernels(kinematics) -> str:
    """C of the kernels of `kinematics`' schemes, printed from the numba templates (:mod:`.translate`)."""
    from .translate import translate

    cell = _cell(kinematics)
    return "\n".join([_text("kernel_support.c")] + [
        translate(text, template.prefix, template.macros or None, names=template.names)
        for template, text in zip(cell.templates, cell.template_texts())])


def _driver(kinematics) -> str:
    """The C of the cell's compiled problems between what a problem is (``problem.h``) and the
    CVODE driver that integrates any (``cvode_driver.c``)."""
    return "\n".join([_text("problem.h"), _cell(kinematics).problem_source(), _text("cvode_driver.c")])


def _lapack_dense(libs: pathlib.Path) -> list[pathlib.Path]:
    """[libsundials_sunlinsollapackdense, libopenblas] where scikit-sundae ships both, else []."""
    found = [sorted(glob.glob(str(libs / f"lib{name}-*.so*"))) for name in ("sundials_sunlinsollapackdense",
                                                                           "openblas*")]
    return [pathlib.Path(f[0]) for f in found] if all(len(f) == 1 for f in found) else []


def _spgmr(libs: pathlib.Path) -> list[pathlib.Path]:
    """[libsundials_sunlinsolspgmr] where scikit-sundae ships it, else []."""
    found = sorted(glob.glob(str(libs / "libsundials_sunlinsolspgmr-*.so*")))
    return [pathlib.Path(found[0])] if len(found) == 1 else []


def sundials() -> tuple[pathlib.Path, list[pathlib.Path], str]:
    """(directory, [libsundials_cvode, libsundials_core(, libsundials_sunlinsollapackdense, libopenblas)
    (, libsundials_sunlinsolspgmr)], index type) of scikit-sundae's SUNDIALS."""
    spec = importlib.util.find_spec("sksundae")  # locates the package without importing it
    if spec is None or spec.origin is None:
        raise NativeUnavailable("scikit-sundae is not installed (its SUNDIALS libraries are needed)")
    package = pathlib.Path(spec.origin).parent
    libs = package.parent / "scikit_sundae.libs"
    found = [sorted(glob.glob(str(libs / f"libsundials_{name}-*.so*"))) for name in ("cvode", "core")]
    if not all(len(f) == 1 for f in found):
        raise NativeUnavailable(f"SUNDIALS libraries (cvode, core) not found in {libs}")
    config = package / "c_config.pxi"
    index = "int"
    if config.is_file():
        for line in config.read_text().splitlines():
            words = line.split()
            if words[-1:] == ["sunindextype"]:
                index = " ".join(words[1:-1])
    if index not in ("int", "long", "long int", "int64_t", "long long"):
        raise NativeUnavailable(f"SUNDIALS index type {index!r} not supported")
    return libs, [pathlib.Path(f[0]) for f in found] + _lapack_dense(libs) + _spgmr(libs), index


def _compiler() -> str:
    cc = shutil.which(os.environ.get("CC", "gcc"))
    if cc is None:
        raise NativeUnavailable(f"no C compiler ({os.environ.get('CC', 'gcc')}) on PATH")
    return cc


#: the source of each cell's kinematics class, found once a process: inspect finds a class by
#: tokenizing its module, which took longer than a small run's solve at every run of a sweep
#: (docs/performance.md; a class's source does not change under the process that loaded it)
_CLASS_SOURCES: dict[type, str] = {}


def _key(rheology, kinematics, libs, index, cc) -> str:
    from ..rheology import codegen

    friction, dilatancy = rheology.material.law_key()
    kind = type(kinematics)
    if kind not in _CLASS_SOURCES:
        _CLASS_SOURCES[kind] = inspect.getsource(kind)
    return "\n".join([
        codegen._generator_key(), codegen._module_source("icidr_pde.rheology.ccode"),
        rheology.definition_key(), type(rheology).__qualname__, friction.__qualname__,
        dilatancy.__qualname__, kind.__qualname__, _CLASS_SOURCES[kind],
        _template(kinematics), _text("sundials_api.h"), _driver(kinematics), codegen._module_source(__name__),
        *map(str, libs), index, cc, *LIBRARY_FLAGS])


def _source(rheology, kinematics, index, libs=()) -> str:
    from ..rheology.ccode import c_law_source

    lapack = any("lapackdense" in pathlib.Path(lib).name for lib in libs)
    spgmr = any("sunlinsolspgmr" in pathlib.Path(lib).name for lib in libs)
    return "\n".join([f"#define SUNINDEXTYPE {index}",
                      "#define ICIDR_LAPACK_DENSE\n#define ICIDR_BLAS" if lapack else "",
                      "#define ICIDR_SPGMR" if spgmr else "",
                      _cell(kinematics).c_defines,
                      _text("sundials_api.h"),
                      c_law_source(rheology, kinematics), _scheme_kernels(kinematics), _driver(kinematics)])


def library(rheology, kinematics) -> ctypes.CDLL:
    """The loaded native library of `rheology` (compiled now if missing; see the docstring)."""
    from .. import kernel_cache
    from ..rheology import codegen

    libdir, libs, index = sundials()
    cc = _compiler()
    name = kernel_cache.stem("native", codegen._digest(_key(rheology, kinematics, libs, index, cc)))
    with _LOCK:
        if name in _LIBRARIES:
            return _LIBRARIES[name]
        for attempt in range(2):
            try:
                found = kernel_cache.read(name, ".so")
                if found is None:
                    note = kernel_cache.read(name, ".unsupported")
                    if note is not None:
                        raise NativeUnavailable(note[1].decode(errors="replace").strip())
                    path = _compile(rheology, kinematics, index, cc, libdir, libs, name)
                else:
                    path = found[0]
            except kernel_cache.KernelCacheError as err:
                raise NativeUnavailable(str(err)) from None
            try:
                lib = ctypes.CDLL(str(path))
                break
            except OSError as err:
                if not path.exists() and attempt == 0:  # removed by a `cache clear` of another process
                    continue
                path.unlink(missing_ok=True)  # rebuilt by the next run
                raise NativeUnavailable(f"native library not loadable: {err}") from None
        _declare(lib, kinematics)
        _LIBRARIES[name] = lib
        return lib


def _compile(rheology, kinematics, index, cc, libdir, libs, name) -> pathlib.Path:
    """Compile the library of `name` into the kernel cache; its path."""
    from .. import kernel_cache
    from ..rheology.ccode import UnsupportedLaw

    try:
        text = _source(rheology, kinematics, index, libs)
    except UnsupportedLaw as err:
        kernel_cache.store(name, ".unsupported", f"{err}\n".encode())
        raise NativeUnavailable(str(err)) from None
    schemes = ", ".join(_cell(kinematics).schemes)
    sys.stderr.write(f"icidr-pde: compiling native kernels for {rheology.name} ({schemes}; once per installation) ...\n")
    sys.stderr.flush()
    start = time.perf_counter()
    path = kernel_cache.build(name, ".so", lambda tmp: _run_compiler(  # the C text on stdin: no C file to plant
        [cc, *LIBRARY_FLAGS, "-o", str(tmp), "-x", "c", "-", "-x", "none", *map(str, libs), f"-Wl,-rpath,{libdir}",
         "-lm"], text))
    sys.stderr.write(f"icidr-pde: native kernels compiled in {time.perf_counter() - start:.1f} s\n")
    sys.stderr.flush()
    return path


def _run_compiler(command, source: str) -> None:
    """Run the compiler on `source`; NativeUnavailable with its first error line (or its exit status) if it fails."""
    try:
        proc = subprocess.run(command, input=source, capture_output=True, text=True, preexec_fn=_die_with_parent)
    except OSError as err:
        raise NativeUnavailable(f"the C compiler {command[0]} could not be run: {err.strerror or err}") from None
    if proc.returncode != 0:
        lines = [line for line in proc.stderr.splitlines() if "error" in line] or proc.stderr.splitlines()
        said = f": {lines[0].strip()}" if lines else " with no message"
        raise NativeUnavailable(f"the C compiler {command[0]} failed (exit status {proc.returncode}){said}")
    if not os.path.getsize(command[command.index("-o") + 1]):
        raise NativeUnavailable(f"the C compiler {command[0]} exited 0 but wrote no library")


def _die_with_parent() -> None:
    """In the compiler's process (Linux): end it when this process dies, so that a killed run leaves
    no compiler writing into the cache."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


#: the driver's functions (cvode_driver.c), name -> "restype: argument types" (:func:`c_types`)
DRIVER_FUNCTIONS = {
    "icidr_rates": "-: P *D *D",
    "icidr_law_M": "-: P I *D *D",
    "icidr_kernel_times": "-: P *D I *D",
    "icidr_krylov_counts": "-: P *L",
    "icidr_blas_threads": "I: I",
    "icidr_cvode_start": "I: P D *D D D D D L L D I S I",
    "icidr_cvode_advance": "I: P I *D *I *D *D *I *I *I",
    "icidr_cvode_last_good": "D: P *D",
    "icidr_cvode_last_step": "D: P *D",
    "icidr_cvode_message": "-: P I S I",
    "icidr_cvode_counts": "-: P *L",
    "icidr_free": "-: P",
}


def c_types(signature: str) -> tuple:
    """(restype, argtypes) of ctypes for "restype: argument types" in letters: P a pointer, D double,
    I int, L long, S char *, a leading * a pointer to that type, '-' no value."""
    letters = {"P": ctypes.c_void_p, "D": ctypes.c_double, "I": ctypes.c_int, "L": ctypes.c_long,
               "S": ctypes.c_char_p}

    def one(word):
        return ctypes.POINTER(letters[word[1:]]) if word.startswith("*") else letters[word]

    restype, _, arguments = signature.partition(":")
    return (None if restype.strip() == "-" else one(restype.strip())), [one(w) for w in arguments.split()]


def _declare(lib, kinematics) -> None:
    """The ctypes signatures of the driver's functions and of those of the cell's problems."""
    for name, signature in {**DRIVER_FUNCTIONS, **_cell(kinematics).c_functions}.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = c_types(signature)
