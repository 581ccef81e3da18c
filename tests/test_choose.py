"""engines.choose: the one choice of engine, Jacobian and linear solver.

Against the schemes themselves: the light table of their Jacobian structures is what each
registered py-pde scheme offers on a state; the choice names what the engine then builds.
"""

import pytest

from icidr_pde.engines.choose import SCHEME_STRUCTURES, JacobianStructure, choose
from icidr_pde.validation import ParameterError


def test_scheme_structures_are_what_the_schemes_offer():
    from icidr_pde.case import build_case

    for name, scene, N in (("fd", "shear", 9), ("cheb", "shear", 9), ("fv2d", "bump2d", (6, 5))):
        case = build_case("icidr", scene, name, N)
        assert JacobianStructure.of(case.pde, case.state) == SCHEME_STRUCTURES[name], name


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
    choice = choose(method=method, jacobian=jacobian, structure=SCHEME_STRUCTURES[scheme], discretization=scheme,
                    request="pde")
    assert (choice.engine, choice.jacobian, choice.linear_solver) == expected and choice.reason == ""


def test_native_where_it_applies_else_the_reason():
    fd = SCHEME_STRUCTURES["fd"]
    assert choose(method="CVODE", structure=fd, discretization="fd").engine == "native"
    for kwargs, why in ((dict(method="BDF"), "method 'BDF'"), (dict(method="CVODE", jacobian="banded-fd"), "jacobian"),
                        (dict(method="CVODE", outputs=["--save"]), "--save"), (dict(method="CVODE", dim=2), "2-D"),
                        (dict(method="CVODE", native_unavailable="no C compiler"), "no C compiler")):
        choice = choose(structure=fd, discretization="fd", request="native", **kwargs)
        assert choice.engine != "native" and why in choice.reason


def test_bad_requests_are_named():
    fd, cheb = SCHEME_STRUCTURES["fd"], SCHEME_STRUCTURES["cheb"]
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
