"""engines.choose: the one choice of engine, Jacobian and linear solver.

Against the schemes themselves: the Jacobian structure the cells state (what the run path
passes in, :func:`icidr_pde.cells.choice_asks`) is what each registered py-pde scheme offers on a
state; the choice names what the engine then builds.
"""

import subprocess
import sys

import pytest

from icidr_pde.cells import cells, choice_asks, get_cell
from icidr_pde.engines.choose import JacobianStructure, choose
from icidr_pde.engines.linear import compiled_solver
from icidr_pde.validation import ParameterError


def test_scheme_structures_are_what_the_schemes_offer():
    from icidr_pde.case import build_case

    for name, scene, N in (("fd", "shear", 9), ("cheb", "shear", 9), ("fv2d", "bump2d", (6, 5))):
        case = build_case("icidr", scene, name, N)
        assert JacobianStructure.of(case.pde, case.state) == JacobianStructure(**choice_asks(name)["structure"]), name


@pytest.mark.parametrize("method, jacobian, scheme, expected", [
    ("CVODE", None, "fd", ("sundae", "analytic", "band LU")),
    ("CVODE", None, "cheb", ("sundae", "analytic", "dense LU (LAPACK)")),
    ("CVODE", None, "fv2d", ("sundae", "fourier", "GMRES + x-Fourier preconditioner")),
    ("CVODE", "krylov", "fv2d", ("sundae", "krylov", "GMRES (line preconditioner in thin cells)")),
    ("CVODE", "banded-fd", "fd", ("sundae", "banded-fd", "band LU")),
    ("CVODE", "sparse", "fv2d", ("sundae", "sparse", "SuperLU_MT")),
    ("BDF", None, "fd", ("scipy", "analytic", "SuperLU")),
    ("BDF", None, "cheb", ("scipy", "analytic", "dense LU (LAPACK)")),
    ("LSODA", None, "fd", ("scipy", "banded-fd", "band LU (LSODA)")),
    ("LSODA", None, "cheb", ("scipy", "analytic", "dense LU (LSODA)")),
])
def test_python_engines(method, jacobian, scheme, expected):
    choice = choose(method=method, jacobian=jacobian, request="pde", **choice_asks(scheme, request="pde"))
    assert (choice.engine, choice.jacobian, choice.linear_solver) == expected and choice.reason == ""


def test_native_where_it_applies_else_the_reason():
    fd = choice_asks("fd", request="native")
    assert choose(method="CVODE", **choice_asks("fd")).engine == "native"
    for kwargs, why in ((dict(method="BDF"), "method 'BDF'"), (dict(method="CVODE", jacobian="banded-fd"), "jacobian"),
                        (dict(method="CVODE", backend="numpy"), "backend 'numpy'"),
                        (dict(method="CVODE", native_unavailable="no C compiler"), "no C compiler")):
        choice = choose(request="native", **fd, **kwargs)
        assert choice.engine != "native" and why in choice.reason
    # a grid of another cell: the cell of the grid says its dimension
    on_plane = choose(method="CVODE", request="native", **choice_asks("fd", get_cell("plane2d"), "native"))
    assert on_plane.engine != "native" and on_plane.reason == "a 2-D grid for discretization 'fd'"


def test_the_native_engine_is_what_the_cells_state():
    """Each scheme's native mode and linear solver are its cell's; a scheme no cell has a compiled
    problem of is refused with the schemes that have one, named from the registry."""
    native = {scheme: how for cell in cells().values() for scheme, how in cell.native.items()}
    assert native and set(choice_asks("fd")["native_schemes"]) == set(native)
    solvers = {"fd": "band LU", "cheb": "GMRES + band preconditioner", "fv2d": "GMRES"}  # what the C problems set up
    for scheme, (mode, *kind) in native.items():
        choice = choose(method="CVODE", **choice_asks(scheme))
        solver = solvers[scheme]
        assert (choice.engine, choice.jacobian, choice.linear_solver, choice.solver.name) == ("native", mode, solver,
                                                                                                solver)
        assert compiled_solver(*kind).name == solver
    with pytest.raises(ValueError, match="linear solver is 'band', 'krylov', 'gmres' or 'dense'"):
        compiled_solver("nothing")
    names = choice_asks("fd")["native_schemes"]
    other = choose(method="CVODE", request="native", **choice_asks("upwind3"))
    assert other.reason == ("discretization 'upwind3' (the native engine has " + ", ".join(names[:-1])
                            + f" and {names[-1]})")
    assert "sparse Jacobian" in str(pytest.raises(ParameterError, choose, method="CVODE", request="petsc",
                                                  **choice_asks("cheb", request="petsc")).value)


def test_choose_imports_no_cell():
    """An engine imports no cell (tests/test_import_graph.py): choose is asked with plain values."""
    code = "import sys, icidr_pde.engines.choose; print(any(m.startswith('icidr_pde.cells') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_bad_requests_are_named():
    fd, cheb = choice_asks("fd")["structure"], choice_asks("cheb")["structure"]
    with pytest.raises(ParameterError, match="`engine`"):
        choose(method="CVODE", structure=fd, request="gpu")
    with pytest.raises(ParameterError, match="`jacobian` must be one of"):
        choose(method="BDF", jacobian="krylov", structure=fd)
    with pytest.raises(ParameterError, match="banded ordering"):
        choose(method="CVODE", jacobian="banded-fd", structure=cheb, request="pde")
    with pytest.raises(ParameterError, match="needs a sparse Jacobian"):
        choose(method="BDF", jacobian="sparse-fd", structure=cheb)


def test_every_result_names_engine_linear_solver_and_jacobian():
    from icidr_pde.api import run

    for kwargs in (dict(method="BDF"), dict(method="CVODE", engine="pde"), dict(method="CVODE")):
        settings = run("icidr", "shear", 9, 0.05, **kwargs).settings
        assert {"engine", "linear_solver", "jacobian"} <= set(settings), kwargs


@pytest.mark.parametrize("kwargs", [dict(method="CVODE"), dict(method="BDF"), dict(method="CVODE", engine="pde"),
                                    dict(method="CVODE", discretization="cheb", N=21)])
def test_rtol_is_validated_once_on_the_way_to_the_engine(monkeypatch, kwargs):
    """A tolerance given to run() is checked once, on every engine's path (issue 22): the
    check is engines.base.check_tolerances, which names rtol to validation.real."""
    from icidr_pde.api import run
    from icidr_pde.engines import base

    seen = []
    real = base.real

    def counting(name, *args, **kw):
        if name == "rtol":
            seen.append(args[0])
        return real(name, *args, **kw)

    monkeypatch.setattr(base, "real", counting)
    result = run("icidr", "shear", t_end=0.1, rtol=1e-5, series_times=[], **{"N": 21, **kwargs})
    assert result.reason == "reached t_end"
    assert seen == [1e-5]
