"""The measurement pages of the site show the data/benchmarks files as the files hold them.

docs/benchmark_pages.py writes one page per file at each build. Truth used: the JSON file itself,
read here with json and walked by the entry path each table row names (``rows[2].fast``); a number
shown agrees when it is the file's value rounded to the digits shown (test_doc_numbers.agrees), a
column a row's entry lacks is looked up in the entries that hold it (a size's N above its runs).
A file the renderer cannot place is listed on the index as raw data, not rendered.
"""

import importlib.util
import json
import re
from pathlib import Path

import pytest

from tests.test_doc_numbers import agrees, command_exists

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "data" / "benchmarks"
FILES = sorted(p for p in BENCHMARKS.iterdir() if p.suffix in (".json", ".jsonl"))

_spec = importlib.util.spec_from_file_location("benchmark_pages", ROOT / "docs" / "benchmark_pages.py")
benchmark_pages = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(benchmark_pages)

_CELL_BAR = re.compile(r"(?<!\\)\|")
_STEP = re.compile(r"\.?([^.\[\]]+)|\[(\d+)\]")


def _tables(page: str) -> list[list[list[str]]]:
    """The cells of each Markdown table of `page` (header row first, the |---| row dropped)."""
    tables, current = [], None
    for line in page.splitlines():
        if line.startswith("|"):
            if current is None:
                current = []
                tables.append(current)
            if not set(line) <= set("|-"):
                current.append([c.strip().replace("\\|", "|") for c in _CELL_BAR.split(line)[1:-1]])
        else:
            current = None
    return tables


def _chain(data, entry: str) -> list:
    """The JSON objects from the file's top down to the one `entry` names."""
    chain = [data]
    if entry != benchmark_pages.TOP_LEVEL:
        for key, index in _STEP.findall(entry.strip("`")):
            chain.append(chain[-1][int(index)] if index else chain[-1][key])
    return chain


def _value_of(chain: list, column: str):
    for obj in reversed(chain):
        if isinstance(obj, dict) and column in obj:
            return obj[column]
    raise KeyError(column)


def mismatches(page: str, data) -> list[str]:
    """The cells of `page`'s tables that are not the value the file holds at their entry."""
    wrong = []
    for table in _tables(page):
        header, rows = table[0], table[1:]
        assert header[0] == "entry", header
        for row in rows:
            chain = _chain(data, row[0])
            for column, cell in zip(header[1:], row[1:]):
                if cell == "":
                    continue
                value = _value_of(chain, column)
                if cell == "—":
                    ok = value is None
                elif isinstance(value, bool):
                    ok = cell == str(value).lower()
                elif isinstance(value, (int, float)):
                    ok = agrees(cell, value)
                else:
                    ok = cell == str(value).replace("\n", " ")
                if not ok:
                    wrong.append(f"{row[0]} {column}: shown {cell!r}, file {value!r}")
    return wrong


def _provenance(page: str) -> dict[str, str]:
    return dict(re.findall(r"^- \*\*([\w ()]+):\*\* (.*)$", page, flags=re.MULTILINE))


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_each_number_shown_is_the_files(path):
    page = benchmark_pages.render(path)
    if page is None:
        pytest.skip(f"{path.name} is listed as raw data (test_every_file_is_placed)")
    data = json.loads(path.read_text())
    assert not mismatches(page, data)
    assert len(_tables(page)) >= 1 and all(len(t) >= 2 for t in _tables(page)), "a table with no row"
    shown = _provenance(page)
    if isinstance(data.get("provenance"), dict):
        assert_recorded(shown, data["provenance"])
        return
    assert_unstamped(shown, data, path.name)


def assert_unstamped(shown: dict[str, str], data: dict, name: str) -> None:
    """The heading of a page whose file was measured before benchmarks/provenance.py: it says
    so, shows what the file records and says "not recorded in the file" of the rest, and quotes
    how the guides say it was made, each quote found in the guide it names."""
    assert shown["Provenance"] == benchmark_pages.UNSTAMPED
    command = data.get("command") or data.get("commands")
    expected = " ; ".join(command) if isinstance(command, list) else command
    assert shown["Command"] == (f"`{expected}`" if expected else "not recorded in the file")
    date = data.get("measured") or data.get("date")
    note = data.get("note") or ""
    assert shown["Date"] == (date or ("as recorded in the note" if re.search(r"\b(19|20)\d\d\b", note)
                                      else "not recorded in the file"))
    if "load" in data:
        load = data["load"] if isinstance(data["load"], list) else [data["load"]]
        cells = shown["Load (as recorded)"].split(", ")
        assert len(cells) == len(load) and all(agrees(c, v) for c, v in zip(cells, load))
    elif "load" in f"{date} {data.get('note')}":
        assert shown["Load"] == "as recorded in the date or note"
    else:
        assert shown["Load"] == "not recorded in the file"
    for label in ("Dated record in a guide", "Command in a guide"):
        if label in shown:
            quoted, guide = re.fullmatch(r"`([^`]+)`.* \((docs/[\w.]+)\)", shown[label]).groups()
            lines = [line for line in (ROOT / guide).read_text().splitlines() if f"data/benchmarks/{name}" in line]
            text = " ".join((ROOT / guide).read_text().replace("\\\n", " ").split())  # continuations joined
            assert lines and quoted in text, (name, label, quoted)
            assert command_exists(quoted), quoted
    if "Written by" in shown:
        script = re.match(r"`python (benchmarks/\w+\.py)`", shown["Written by"]).group(1)
        assert (ROOT / script).is_file() and name.startswith(Path(script).stem), name


def assert_recorded(shown: dict[str, str], record: dict) -> None:
    """The heading of a page whose file benchmarks/provenance.py stamped shows that record."""
    assert shown["Command"] == f"`{record['command']}`"
    assert shown["Date"] == record["date"]
    for moment in ("start", "end"):
        cells = shown[f"Load at {moment}"].split(", ")
        assert len(cells) == 3 and all(agrees(c, v) for c, v in zip(cells, record["load"][moment]))
    assert shown["Commit"].startswith(f"`{record['commit']}`")
    assert shown["Machine"].startswith(f"{record['cores']} cores, ")


def test_every_file_is_placed(tmp_path):
    """Each data file has its page or is listed as raw data on the index, none skipped."""
    placed = benchmark_pages.write_pages(BENCHMARKS, tmp_path)
    index = (tmp_path / "index.md").read_text()
    assert set(placed) == {p.name for p in FILES}
    for name, page in placed.items():
        if page:
            assert (tmp_path / f"{page}.md").is_file() and re.search(rf"^{re.escape(page)}$", index, re.MULTILINE)
        else:
            assert f"`data/benchmarks/{name}`: raw data, not rendered" in index
    # the files that record their command, date or load and hold rows of runs are rendered
    for name in ("startup.json", "end_to_end_fd.json", "end_to_end_cheb.json", "sim2d_speed.json",
                 "shortwave2d.json", "amg2d.json", "scaling.json"):
        assert placed[name] == Path(name).stem, name


def test_a_file_the_renderer_cannot_place_is_listed_raw(tmp_path):
    data_dir = tmp_path / "benchmarks"
    data_dir.mkdir()
    (data_dir / "series.json").write_text(json.dumps([1.0, 2.0]))  # no table the renderer knows
    (data_dir / "unplaced.json").write_text(json.dumps({"rows": [{"N": 8, "wall_s": 0.5}]}))  # no command/date/load
    (data_dir / "log.jsonl").write_text('{"N": 8}\n{"N": 16}\n')
    (data_dir / "run.json").write_text(json.dumps({"command": "python b.py", "rows": [{"N": 8, "wall_s": 0.123456}]}))
    placed = benchmark_pages.write_pages(data_dir, tmp_path / "out")
    assert placed == {"series.json": None, "unplaced.json": None, "log.jsonl": None, "run.json": "run"}
    index = (tmp_path / "out" / "index.md").read_text()
    for name in ("series.json", "unplaced.json", "log.jsonl"):
        assert f"`data/benchmarks/{name}`: raw data, not rendered" in index
    page = (tmp_path / "out" / "run.md").read_text()
    # what the file does not record is said so, not made up
    assert _provenance(page) == {"Provenance": benchmark_pages.UNSTAMPED, "Command": "`python b.py`",
                                 "Date": "not recorded in the file", "Load": "not recorded in the file"}
    assert _tables(page)[-1] == [["entry", "N", "wall_s"], ["`rows[0]`", "8", "0.1235"]]


def test_a_changed_number_is_found():
    """The check can fail: a page whose cell or whose rounding differs from the file's."""
    path = BENCHMARKS / "startup.json"
    data = json.loads(path.read_text())
    page = benchmark_pages.render(path)
    assert not mismatches(page, data)
    shown = benchmark_pages._shown(data["rows"][0]["wall_s"])
    other = json.loads(path.read_text())
    other["rows"][0]["wall_s"] *= 1.01
    assert mismatches(page, other) == [f"`rows[0]` wall_s: shown {shown!r}, file {other['rows'][0]['wall_s']!r}"]
    assert mismatches(page.replace(f"| {shown} |", f"| {shown}1 |", 1), data)


def test_the_provenance_record_is_preferred(tmp_path):
    """A file measured again after benchmarks/provenance.py: its page shows the record under
    "provenance", not the older keys the benchmark still writes beside it."""
    record = {"command": "nice -n 10 python benchmarks/amg2d.py --sizes 64", "argv": ["benchmarks/amg2d.py", "--sizes", "64"],
              "date": "2026-12-07T18:00:00+00:00", "finished": "2026-12-07T18:20:00+00:00",
              "load": {"start": [1.23456, 2.0, 3.5], "end": [0.5, 0.25, 0.125]}, "cores": 2, "memory_gib": 23.54,
              "python": "3.11.7", "platform": "Linux-6.1-x86_64", "commit": "0123abcd" * 5, "modified": True}
    data = {"provenance": record, "command": "python benchmarks/amg2d.py", "load": [9.0, 9.0, 9.0],
            "measured": "2026-11-01", "gamma": 0.5, "rows": [{"N": 64, "solve_s": 1.23456}]}
    path = tmp_path / "amg2d.json"
    path.write_text(json.dumps(data))
    page = benchmark_pages.render(path)
    shown = _provenance(page)
    assert shown == {"Command": "`nice -n 10 python benchmarks/amg2d.py --sizes 64`", "Date": "2026-12-07T18:00:00+00:00",
                     "Load at start": "1.235, 2, 3.5", "Load at end": "0.5, 0.25, 0.125",
                     "Machine": "2 cores, 23.54 GiB, Python 3.11.7, Linux-6.1-x86_64",
                     "Commit": f"`{'0123abcd' * 5}` (tracked files modified)"}
    assert_recorded(shown, record)
    assert not mismatches(page, data)
    # the record is no setting, and the settings and rows are the file's
    assert _tables(page) == [[["entry", "gamma"], ["(top level)", "0.5"]],
                             [["entry", "N", "solve_s"], ["`rows[0]`", "64", "1.235"]]]
    # a record without loads says so; a file with only the record is rendered
    del record["load"]
    path.write_text(json.dumps({"provenance": record, "rows": [{"N": 8}]}))
    assert _provenance(benchmark_pages.render(path))["Load"] == "not recorded"


def test_a_file_the_helper_writes_is_rendered_with_its_record(tmp_path):
    spec = importlib.util.spec_from_file_location("provenance", ROOT / "benchmarks" / "provenance.py")
    provenance = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(provenance)
    path = tmp_path / "run.json"
    provenance.write_json(path, {"rows": [{"N": 8, "wall_s": 0.5}]}, argv=["benchmarks/amg2d.py", "--sizes", "8"])
    data = json.loads(path.read_text())
    page = benchmark_pages.render(path)
    assert_recorded(_provenance(page), data["provenance"])
    assert not mismatches(page, data)


def test_every_committed_file_says_whether_it_is_stamped(tmp_path):
    """A file measured before benchmarks/provenance.py says so on its page or its line of the
    index, with how a guide says it was made where one does; a stamped file shows its record."""
    placed = benchmark_pages.write_pages(BENCHMARKS, tmp_path)
    index = (tmp_path / "index.md").read_text()
    stamped = []
    for path in FILES:
        first = path.read_text().splitlines()[0] if path.suffix == ".jsonl" else path.read_text()
        data = json.loads(first)
        record = isinstance(data, dict) and isinstance(data.get("provenance"), dict)
        stamped += [path.name] if record else []
        if placed[path.name]:
            shown = _provenance((tmp_path / f"{placed[path.name]}.md").read_text())
            if record:
                assert_recorded(shown, data["provenance"])
            else:
                assert_unstamped(shown, data, path.name)
        else:
            line = next(line for line in index.splitlines() if f"`data/benchmarks/{path.name}`" in line)
            assert ("stamped: `" in line) if record else (benchmark_pages.UNSTAMPED in line), line
    # measured again with the stamp (docs/performance.md and docs/chebyshev.md quote their t*)
    assert {"cheb_krylov_rtol.json", "cheb_krylov_tstar.json"} <= set(stamped)


def test_where_the_guides_say_a_file_was_made(tmp_path):
    """A dated record naming the file wins over a command in a code block, which wins over the
    benchmark whose default output it is, which wins over the benchmark it is named after."""
    docs, bench = tmp_path / "docs", tmp_path / "benchmarks"
    docs.mkdir()
    bench.mkdir()
    (bench / "speed.py").write_text('parser.add_argument("--json", default="data/benchmarks/speed.json")\n')
    (bench / "sweep.py").write_text("")
    (docs / "a.md").write_text(
        "```bash\nnice -n 10 python benchmarks/speed.py --sizes 8 \\\n    --json data/benchmarks/speed_8.json\n```\n\n"
        "*Dated record*: `python benchmarks/speed.py --sizes 9 --json data/benchmarks/speed_9.json`, 2026-12-01, "
        "the shared 2-core machine at load 3\n\n"
        "```bash\npython benchmarks/speed.py --sizes 9 --json data/benchmarks/speed_9.json\n```\n"
        "(the 16 run: `--sizes 16 --json data/benchmarks/speed_16.json`)\n")

    def sources(name):
        return benchmark_pages.guide_sources(name, docs, bench)

    assert sources("speed_9.json") == [
        "- **Dated record in a guide:** `python benchmarks/speed.py --sizes 9 --json data/benchmarks/speed_9.json`, "
        "2026-12-01, the shared 2-core machine at load 3 (docs/a.md)"]
    assert sources("speed_8.json") == [
        "- **Command in a guide:** `nice -n 10 python benchmarks/speed.py --sizes 8 --json data/benchmarks/speed_8.json` "
        "(docs/a.md)"]
    assert sources("speed.json") == ["- **Written by:** `python benchmarks/speed.py` (its default output; "
                                     "the arguments are not recorded)"]
    assert sources("speed_16.json") == [
        "- **Written by:** `python benchmarks/speed.py` (the benchmark the file is named after; the arguments a "
        "guide quotes: `--sizes 16 --json data/benchmarks/speed_16.json` (docs/a.md))"]
    assert sources("sweep_x.json")[0].endswith("(the benchmark the file is named after; no guide quotes its arguments)")
    assert sources("other.json") == []
