"""Resumable sweeps: ``icidr-pde tstar --cache DIR`` (icidr_pde.studies.case_cache).

Truth: the same sweep run without a cache (its JSON), and the count of runs actually made
(a case taken from the cache runs nothing).
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest

from icidr_pde.cli import main
from icidr_pde.studies import case_cache

ft = importlib.import_module("icidr_pde.studies.failure_time")  # the module (the package exports its function)

ARGV = ["tstar", "--discretization", "fd", "--N", "21,25,29", "--t-end", "0.02", "--accuracy", "paper", "--jobs", "1",
        "--no-progress"]


@pytest.fixture
def counted(monkeypatch):
    """failure_time wrapped: the N of every run made, and an optional interrupt at the k-th run."""
    real = ft.failure_time
    made: list[int] = []
    state = {"interrupt_at": None}

    def wrapper(**kwargs):
        if state["interrupt_at"] is not None and len(made) == state["interrupt_at"]:
            raise KeyboardInterrupt
        made.append(kwargs["N"])
        return real(**kwargs)

    monkeypatch.setattr(ft, "failure_time", wrapper)
    return made, state


@pytest.fixture(scope="module")
def uncached(tmp_path_factory):
    out = tmp_path_factory.mktemp("plain") / "t.json"
    assert main([*ARGV, "--json", str(out)]) == 0
    return json.loads(out.read_text())


def test_an_interrupted_sweep_resumes_to_the_uncached_json(counted, uncached, tmp_path):
    made, state = counted
    cache, out = tmp_path / "cache", tmp_path / "t.json"
    state["interrupt_at"] = 2
    assert main([*ARGV, "--cache", str(cache), "--json", str(out)]) == 130
    assert len(made) == 2 and len(case_cache.CaseCache(cache, "failure_time")) == 2  # the finished ones kept
    written = json.loads(out.read_text())["discretizations"]["fd"]["t_star"]  # and written (issue 42, item 14)
    assert len(written) == 2 and all(uncached["discretizations"]["fd"]["t_star"][n] == t for n, t in written.items())
    state["interrupt_at"] = None
    assert main([*ARGV, "--cache", str(cache), "--json", str(out)]) == 0
    assert len(made) == 3                       # only the case that had not finished ran
    assert json.loads(out.read_text()) == uncached
    assert main([*ARGV, "--cache", str(cache), "--json", str(out)]) == 0
    assert len(made) == 3 and json.loads(out.read_text()) == uncached  # all three from the cache


def test_a_corrupt_or_foreign_entry_is_run_again(counted, uncached, tmp_path):
    made, _ = counted
    cache, out = tmp_path / "cache", tmp_path / "t.json"
    assert main([*ARGV, "--cache", str(cache), "--json", str(out)]) == 0
    entries = sorted(cache.glob("*.json"))
    entries[0].write_text(entries[0].read_text()[:40])                  # cut short
    entry = json.loads(entries[1].read_text())
    entry["case"]["N"] = 999                                             # not the case of its key
    entries[1].write_text(json.dumps(entry))
    del made[:]
    assert main([*ARGV, "--cache", str(cache), "--json", str(out)]) == 0
    assert len(made) == 2 and json.loads(out.read_text()) == uncached
    assert all(json.loads(p.read_text())["key"] == p.stem for p in entries)  # rewritten whole


@pytest.mark.parametrize("change", [["--rtol", "1e-7"], ["--method", "Radau"], ["--t-end", "0.03"]])
def test_a_changed_setting_does_not_reuse_the_entries(counted, tmp_path, change):
    made, _ = counted
    cache = tmp_path / "cache"
    assert main([*ARGV, "--cache", str(cache)]) == 0
    assert main([*ARGV, *change, "--cache", str(cache)]) == 0
    assert len(made) == 6 and len(case_cache.CaseCache(cache, "failure_time")) == 6


def test_changed_code_does_not_reuse_the_entries(counted, tmp_path, monkeypatch):
    made, _ = counted
    cache = tmp_path / "cache"
    assert main([*ARGV, "--cache", str(cache)]) == 0
    monkeypatch.setattr(case_cache, "_VERSION", ["another code version"])
    assert main([*ARGV, "--cache", str(cache)]) == 0
    assert len(made) == 6


def test_a_changed_law_file_does_not_reuse_the_entries(tmp_path):
    """A case whose law is a file (``tstar --rheology law.toml --cache DIR``) is keyed by the file's text
    too: an edited law at the same path is another case."""
    law = tmp_path / "law.toml"
    source = (Path(__file__).resolve().parents[1] / "examples" / "half_rate_law.toml").read_text()
    law.write_text(source)
    cache = case_cache.CaseCache(tmp_path / "cache", "failure_time")
    case = {"rheology": str(law), "N": 21}
    first = cache.key(case)
    assert cache.key(dict(case)) == first
    law.write_text(source.replace("k = 0.5", "k = 0.25"))
    assert cache.key(case) != first
    law.write_text(source)
    assert cache.key(case) == first
    assert cache.key({"rheology": "mui", "N": 21}) != cache.key({"rheology": "icidr", "N": 21})


def test_the_code_version_hashes_the_sources(tmp_path, monkeypatch):
    first = case_cache.code_version()
    monkeypatch.setattr(case_cache, "_VERSION", [])
    assert case_cache.code_version() == first  # the same sources, the same version
    assert len(first) == 16


def test_a_cache_that_is_a_file_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "file"
    path.write_text("")
    assert main([*ARGV, "--cache", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "`--cache` must be a directory" in err[0]


def test_a_case_of_other_values_is_refused(tmp_path):
    with pytest.raises(ValueError, match="`cache` keeps cases of JSON values"):
        case_cache.CaseCache(tmp_path, "f").key({"scene": object()})


# --- the 2-D studies and grid convergence resume from a cache ----------------------------------

def _no_run(*args, **kwargs):
    raise AssertionError("a run was made where the cache holds its result")


def _without_wall(payload: dict) -> dict:
    runs = {n: {k: v for k, v in run.items() if k != "wall_s"} for n, run in payload.get("runs", {}).items()}
    return {**payload, "runs": runs}


@pytest.mark.parametrize("study, args", [
    ("convergence_study", dict(sizes=(8, 16), times=("0.05", "0.1"))),
    ("tstar_study", dict(sizes=(8, 12), t_end=0.1)),
    ("growth_study", dict(angles=(45.0,), n=8)),
])
def test_a_2d_study_rerun_from_its_cache_runs_nothing_and_gives_the_same_numbers(study, args, tmp_path,
                                                                                   monkeypatch):
    from icidr_pde import api
    from icidr_pde.studies import sim2d

    plain = getattr(sim2d, study)(**args, path=tmp_path / "plain.json")
    first = getattr(sim2d, study)(**args, path=tmp_path / "cached.json", cache=tmp_path / "cache")
    # the uncached study's numbers (its command names its own --json)
    assert _without_wall(first) == {**_without_wall(plain), "command": first["command"]}
    written = json.loads((tmp_path / "cached.json").read_text())
    monkeypatch.setattr(api, "run", _no_run)
    again = getattr(sim2d, study)(**args, path=tmp_path / "cached.json", cache=tmp_path / "cache")
    assert again == first
    assert json.loads((tmp_path / "cached.json").read_text()) == written


def test_grid_convergence_rerun_from_its_cache_runs_nothing_and_gives_the_same_numbers(tmp_path, monkeypatch,
                                                                                      capsys):
    from icidr_pde.studies import grid_convergence

    argv = ["--t", "0.05", "--N", "11", "21", "--ref", "41", "--no-progress", "--cache", str(tmp_path / "c")]
    plain = grid_convergence.convergence_study("icidr", "sine", 0.05, (11, 21), 41, progress=False)
    assert main(["study", "grid-convergence", *argv, "--json", str(tmp_path / "first.json")]) == 0
    assert json.loads((tmp_path / "first.json").read_text()) == plain
    assert len(case_cache.CaseCache(tmp_path / "c", "grid_convergence")) == 3
    monkeypatch.setattr(grid_convergence, "run", _no_run)
    assert main(["study", "grid-convergence", *argv, "--json", str(tmp_path / "again.json")]) == 0
    assert json.loads((tmp_path / "again.json").read_text()) == plain


def test_a_study_cache_that_is_a_file_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "file"
    path.write_text("")
    for study in (["grid-convergence"], ["sim2d", "tstar"]):
        assert main(["study", *study, "--cache", str(path), "--no-progress"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert "`--cache` must be a directory" in err[-1] and not any("Traceback" in line for line in err)


def test_a_run_interrupted_inside_a_2d_study_is_not_kept(monkeypatch, tmp_path):
    """The run path turns Ctrl-C into a Result ("interrupted at t = ..."); a study taking that as its
    case's answer kept it in its cache and its table (a 2048^2 run stopped after two hours was cached
    as finished). The study stops at it instead, with the grids finished before kept."""
    import dataclasses

    import icidr_pde.api as api
    from icidr_pde.studies import sim2d
    from icidr_pde.studies.parallel import StudyInterrupted

    real, made = api.run, []

    def run(*args, **kwargs):
        result = real(*args, **kwargs)
        made.append(result)
        if len(made) == 2:  # the second grid: as if Ctrl-C came during it
            return dataclasses.replace(result, reason=f"interrupted at t = {result.t_final / 2:g}")
        return result

    monkeypatch.setattr(api, "run", run)
    cache = tmp_path / "cache"
    with pytest.raises(StudyInterrupted):
        sim2d.convergence_study((8, 12), ("0.5",), tmp_path / "c.json", cache=cache)
    assert len(made) == 2 and len(case_cache.CaseCache(cache, "sim2d.convergence")) == 1
    assert not (tmp_path / "c.json").exists()
