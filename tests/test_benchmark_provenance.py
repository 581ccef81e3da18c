"""benchmarks/provenance.py: what a benchmark's JSON records about its run, and that every benchmark
writes its JSON through it.

Truth used: the command is split back with shlex and must give the arguments the process received;
the date must parse as ISO 8601 with a zero UTC offset and lie between the test's own clock
readings; the loads are compared with /proc/loadavg read beside the record; the commit with
``git log -1`` of the checkout; a benchmark run as a user types it (``nice``, a thread-count
variable, an argument with a space) must record that command word for word. The scan of
benchmarks/*.py is checked on sources that write JSON by hand.
"""

import ast
import importlib.util
import json
import os
import shlex
import subprocess
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"

_spec = importlib.util.spec_from_file_location("provenance", BENCHMARKS / "provenance.py")
provenance = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(provenance)

HELPERS = ("write_json", "append_jsonl")


def _python_argv(command: str) -> list[str]:
    """The arguments after ``python`` of `command`, its environment assignments and ``nice -n K``
    taken off (what a shell would run)."""
    words = shlex.split(command)
    while words and "=" in words[0] and words[0].split("=")[0].isidentifier():
        words = words[1:]
    if words[:2] == ["nice", "-n"]:
        words = words[3:]
    assert words[0] == "python", command
    return words[1:]


def _proc_loadavg() -> list[float]:
    return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]


def test_the_record_of_a_run():
    before = datetime.now(timezone.utc).replace(microsecond=0)
    argv = [str(BENCHMARKS / "amg2d.py"), "--sizes", "64", "128", "--note", "two words; $HOME"]
    loads = [_proc_loadavg()] if Path("/proc/loadavg").exists() else []
    r = provenance.record(argv)
    loads += [_proc_loadavg()] if loads else []
    after = datetime.now(timezone.utc)
    # the command runs the same script from the checkout's root with the same arguments
    assert _python_argv(r["command"]) == ["benchmarks/amg2d.py", *argv[1:]]
    assert r["argv"] == argv
    niceness = os.nice(0)
    assert (f"nice -n {niceness} python " in r["command"]) == (niceness > 0)
    # UTC ISO date-times: the start (this module's import, before this test) and the record
    start, finished = datetime.fromisoformat(r["date"]), datetime.fromisoformat(r["finished"])
    assert start.utcoffset() == timedelta(0) and finished.utcoffset() == timedelta(0)
    assert start <= before <= finished <= after
    # the load averages over 1, 5 and 15 minutes at start and end, as the kernel reports them
    for moment in ("start", "end"):
        assert len(r["load"][moment]) == 3 and all(isinstance(x, float) and x >= 0 for x in r["load"][moment])
    if loads:  # /proc/loadavg shows two decimals; the end is one of the readings beside it
        assert any(all(abs(a - b) <= 0.006 for a, b in zip(r["load"]["end"], reading)) for reading in loads)
    # the machine and the tree
    assert r["cores"] == os.cpu_count() and r["memory_gib"] > 0
    assert r["python"] == ".".join(map(str, sys.version_info[:3]))
    head = subprocess.run(["git", "-C", str(ROOT), "log", "-1", "--format=%H"], capture_output=True, text=True)
    if head.returncode:
        pytest.skip("not a git checkout")
    assert r["commit"] == head.stdout.strip() and len(r["commit"]) == 40
    assert isinstance(r["modified"], bool)


def test_outside_a_checkout_the_commit_is_unknown(tmp_path, monkeypatch):
    monkeypatch.setattr(provenance, "ROOT", tmp_path)
    monkeypatch.setenv("GIT_CEILING_DIRECTORIES", str(tmp_path.parent))  # no checkout above tmp_path either
    r = provenance.record(["benchmarks/x.py"])
    assert r["commit"] == "unknown" and r["modified"] is None


def test_a_run_records_the_command_as_typed():
    """``OMP_NUM_THREADS=1 nice -n 3 python benchmarks/provenance.py ...`` run as a user would,
    from the checkout's root: the record gives that command back word for word."""
    env = {k: v for k, v in os.environ.items() if k not in provenance.THREADS}
    env.update(OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    args = ["--sizes", "64", "a b"]
    proc = subprocess.run(["nice", "-n", "3", sys.executable, "benchmarks/provenance.py", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, check=True)
    r = json.loads(proc.stdout)
    niceness = min(os.nice(0) + 3, 19)
    assert r["command"] == f"OMP_NUM_THREADS=1 nice -n {niceness} python benchmarks/provenance.py --sizes 64 'a b'"
    assert r["argv"] == ["benchmarks/provenance.py", *args]


def test_write_json_stamps_and_replaces(tmp_path):
    path = tmp_path / "out" / "run.json"
    provenance.write_json(path, {"rows": [{"N": 8, "wall_s": 0.5}]}, argv=["benchmarks/amg2d.py", "--sizes", "8"])
    data = json.loads(path.read_text())
    assert data["rows"] == [{"N": 8, "wall_s": 0.5}]
    assert _python_argv(data[provenance.KEY]["command"]) == ["benchmarks/amg2d.py", "--sizes", "8"]
    provenance.write_json(path, {"internal": 1}, stamp=False)
    assert json.loads(path.read_text()) == {"internal": 1}


def test_a_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "run.json"
    path.write_text('{"rows": [1]}')
    with pytest.raises(TypeError):
        provenance.write_json(path, {"rows": [object()]})  # JSON cannot hold it
    assert path.read_text() == '{"rows": [1]}'

    def fails(value):
        raise RuntimeError("interrupted while serialising")

    with pytest.raises(RuntimeError):
        provenance.write_json(path, {"rows": [1, {2}]}, default=fails)
    assert path.read_text() == '{"rows": [1]}'
    assert [p.name for p in tmp_path.iterdir()] == ["run.json"]  # no temporary file left


def test_append_jsonl_keeps_every_line(tmp_path):
    path = tmp_path / "cases.jsonl"
    path.write_text('{"case": "old"}')  # a last line without its newline
    provenance.append_jsonl(path, {"case": "a", "N": 8}, argv=["benchmarks/tstar2d_solvers.py"])
    provenance.append_jsonl(path, {"case": "b", "N": 16}, argv=["benchmarks/tstar2d_solvers.py"])
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    assert [r["case"] for r in rows] == ["old", "a", "b"]
    assert all(provenance.KEY in r for r in rows[1:])
    with pytest.raises(TypeError):
        provenance.append_jsonl(path, {"case": object()})
    assert [json.loads(line)["case"] for line in path.read_text().splitlines()] == ["old", "a", "b"]


# --- every benchmark writes its JSON through the helper ------------------------------------------


def _is_json_dumps(node) -> bool:
    return (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in ("dumps", "dump")
            and isinstance(node.func.value, ast.Name) and node.func.value.id == "json")


def hand_written_json(source: str) -> list[int]:
    """Lines of `source` that write JSON without the helper: ``json.dump(...)`` into a file, or a
    ``write``/``write_text`` whose argument holds ``json.dumps(...)`` (printing it is no file)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        if _is_json_dumps(node) and node.func.attr == "dump":
            lines.append(node.lineno)
        elif (isinstance(node.func, ast.Attribute) and node.func.attr in ("write", "write_text", "write_bytes")
              and any(_is_json_dumps(sub) for arg in node.args for sub in ast.walk(arg))):
            lines.append(node.lineno)
    return sorted(lines)


def helper_calls(source: str) -> list[str]:
    """The helpers of benchmarks/provenance.py that `source` imports and calls."""
    tree = ast.parse(source)
    imported = {alias.asname or alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and node.module == "provenance" for alias in node.names}
    return sorted({node.func.id for node in ast.walk(tree) if isinstance(node, ast.Call)
                   and isinstance(node.func, ast.Name) and node.func.id in imported & set(HELPERS)})


SCRIPTS = sorted(p for p in BENCHMARKS.glob("*.py") if p.name != "provenance.py")


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: p.name)
def test_every_benchmark_writes_json_through_the_helper(path):
    source = path.read_text()
    assert not hand_written_json(source), f"{path.name} writes JSON by hand at lines {hand_written_json(source)}"
    # a benchmark with a JSON output (--json, --out, a data file) writes it with the helper
    if "--json" in source or "--out" in source or ".json" in source and "write" in source:
        assert helper_calls(source), f"{path.name} names a JSON output but never calls write_json or append_jsonl"


def test_the_scan_finds_json_written_by_hand():
    cases = {
        "import json\njson.dump(data, open('x.json', 'w'))\n": [2],
        "import json\nPath(p).write_text(json.dumps(dict(load=1, rows=rows), indent=1))\n": [2],
        "import json\nwith open(p, 'a') as f:\n    f.write(json.dumps(row) + '\\n')\n": [3],
        "import json\nprint(json.dumps(row))\n": [],
        "from provenance import write_json\nwrite_json(p, data)\n": [],
    }
    for source, lines in cases.items():
        assert hand_written_json(source) == lines, source
    assert helper_calls("from provenance import write_json\nwrite_json(p, data)\n") == ["write_json"]
    assert helper_calls("from provenance import write_json\n") == []
    assert helper_calls("def write_json(p, d): ...\nwrite_json(p, data)\n") == []
