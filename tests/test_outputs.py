"""Output files (issue 26, items 1, 5, 6, 7, 13, 17, 21, 22; issue 21's umask defect).

The rules (docs/security.md, "Output files"): written whole or not at all, with the mode a
plain ``open(path, "w")`` gives (0o666 less the umask; an existing file keeps its mode),
through a symbolic link to its target (the link stays), through to a device or FIFO, and
checked before any work, two outputs never onto one file. Every finished output is written
before the next starts; a full disk or an interrupt keeps what was computed and written.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import stat
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from icidr_pde import cli

ROOT = Path(__file__).resolve().parents[1]
RUN = ["run", "--N", "9", "--t-end", "0.1", "--no-progress"]


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def leftovers(folder) -> list[str]:
    return sorted(p.name for p in Path(folder).iterdir() if "partial" in p.name or p.name.startswith(".probe"))


@pytest.fixture
def umask_027():
    old = os.umask(0o027)
    yield 0o640
    os.umask(old)


def json_at(path) -> dict:
    return json.loads(Path(path).read_text())


def mount_tmpfs(folder, options):
    """Mount a tmpfs on `folder` (root only; skip where the machine does not allow it)."""
    folder.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.decode().strip()}")
    return folder


@pytest.fixture
def tiny_disk(tmp_path):
    folder = mount_tmpfs(tmp_path / "full", "size=8k")
    yield folder
    subprocess.run(["umount", str(folder)], check=False)


@pytest.fixture
def read_only_folder(tmp_path):
    folder = mount_tmpfs(tmp_path / "ro", "ro,size=8k")
    yield folder
    subprocess.run(["umount", str(folder)], check=False)


# --- modes (items 21 and 22) -------------------------------------------------------------------


@pytest.mark.parametrize("option, name", [("--json", "r.json"), ("--plot", "p.png"), ("--save", "s.h5")])
def test_new_outputs_follow_the_umask(tmp_path, umask_027, option, name):
    target = tmp_path / name
    assert cli.main([*RUN, option, str(target)]) == 0
    assert mode(target) == umask_027


def test_a_rewritten_output_keeps_its_mode(tmp_path, umask_027):
    target = tmp_path / "r.json"
    target.write_text("{}")
    os.chmod(target, 0o664)
    assert cli.main([*RUN, "--json", str(target)]) == 0
    assert mode(target) == 0o664
    assert json_at(target)["N"] == 9


def test_stability_outputs_follow_the_umask(tmp_path, umask_027):
    from icidr_pde.cli import stability

    out, png = tmp_path / "s.json", tmp_path / "p.png"
    import argparse

    parser = argparse.ArgumentParser()
    stability.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["stability", "--rheology", "mui", "--phi", "0.78", "--velocity-gradient", "0",
                              str(1 / 30), "0", "0", "--angles", "0:180:10", "--json", str(out), "--plot", str(png)])
    assert stability.cmd(args) == 0
    assert mode(out) == mode(png) == umask_027


# --- symbolic links, devices, FIFOs (item 1) -----------------------------------------------------


def test_json_through_a_symlink_replaces_the_target_and_keeps_the_link(tmp_path):
    real, link = tmp_path / "real.json", tmp_path / "link.json"
    real.write_text("{}")
    link.symlink_to(real.name)
    assert cli.main([*RUN, "--json", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == real.name
    assert json_at(real)["N"] == 9
    assert leftovers(tmp_path) == []


def test_json_onto_a_fifo_is_written_through(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_text()), daemon=True)
    reader.start()
    assert cli.main([*RUN, "--json", str(fifo)]) == 0
    reader.join(timeout=30)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)  # still the FIFO
    assert json.loads(received[0])["N"] == 9


def test_json_onto_a_character_device_is_written_through(tmp_path):
    null = tmp_path / "null"
    try:
        os.mknod(null, 0o666 | stat.S_IFCHR, os.makedev(1, 3))  # the null device, in a scratch folder
    except (PermissionError, OSError) as err:
        pytest.skip(f"cannot make a device node: {err}")
    assert cli.main([*RUN, "--json", str(null)]) == 0
    assert stat.S_ISCHR(os.stat(null).st_mode)
    assert leftovers(tmp_path) == []


def test_json_to_stdout_redirected_to_a_file_is_the_whole_file(tmp_path):
    out = tmp_path / "out.txt"
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    with open(out, "w") as fh:
        done = subprocess.run([sys.executable, "-m", "icidr_pde.cli", *RUN, "--json", "/dev/stdout"],
                              stdout=fh, stderr=subprocess.PIPE, env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr.decode()
    text = out.read_text()
    assert out.is_file() and not out.is_symlink()
    assert json.loads(text)["N"] == 9  # written through the redirect, and nothing else: the summary
    assert "Result(" in done.stderr.decode()  # went to stderr


def test_planted_link_at_a_guessable_temporary_name_is_not_followed(tmp_path, capsys):
    """`law check --json r.json` wrote through `.r.json.tmp`, following a link planted there
    into another file (issue 26, item 21)."""
    victim, report = tmp_path / "victim.txt", tmp_path / "r.json"
    victim.write_text("precious")
    (tmp_path / ".r.json.tmp").symlink_to(victim)
    assert cli.main(["law", "check", "icidr", "--no-curves", "--json", str(report)]) == 0
    assert victim.read_text() == "precious"
    assert report.is_file() and not report.is_symlink() and json_at(report)["law"] == "icidr"


# --- one file, two outputs (item 6) ----------------------------------------------------------------


@pytest.mark.parametrize("first, second, name", [("--json", "--save", "x.h5"), ("--json", "--plot", "a.png"),
                                                 ("--save", "--movie", "x.gif")])
def test_two_outputs_onto_one_file_are_refused(tmp_path, capsys, first, second, name):
    target = tmp_path / name
    assert cli.main([*RUN, first, str(target), second, str(target)]) == 2
    captured = capsys.readouterr()
    assert first in captured.err and second in captured.err and "same file" in captured.err
    assert "Result(" not in captured.out and not target.exists()


def test_two_outputs_onto_one_file_through_a_link_are_refused(tmp_path, capsys):
    (tmp_path / "link.h5").symlink_to("x.h5")
    status = cli.main([*RUN, "--json", str(tmp_path / "x.h5"), "--save", str(tmp_path / "link.h5")])
    assert status == 2 and "same file" in capsys.readouterr().err


# --- every output checked before any work (item 13) ------------------------------------------------


def _stability_argv(option, path):
    return ["stability", "--rheology", "mui", "--phi", "0.78", "--uz", "0.03", "--wz", "0", option, path]


@pytest.mark.parametrize("argv", [
    ["verify", "--json", "/nonexistent/v.json"],
    ["verify", "--markdown", "/nonexistent/v.md"],
    ["tstar", "--N", "9", "--t-end", "0.01", "--jobs", "1", "--no-progress", "--json", "/nonexistent/t.json"],
    ["tstar", "--N", "9", "--t-end", "0.01", "--jobs", "1", "--no-progress", "--plot", "/nonexistent/t.png"],
    ["law", "check", "icidr", "--no-curves", "--json", "/nonexistent/r.json"],
    ["figures", "--only", "fig3", "--draft", "--out", "/proc/nope"],
    _stability_argv("--json", "/nonexistent/s.json"),
    ["stability", "--rheology", "mui", "--phi", "0.78", "--velocity-gradient", "0", "0.03", "0", "0",
     "--plot", "/nonexistent/s.png"],
], ids=["verify-json", "verify-markdown", "tstar-json", "tstar-plot", "law-check", "figures", "stability-json",
        "stability-plot"])
def test_unwritable_outputs_are_refused_before_any_work(capsys, argv):
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert "nonexistent" in captured.err or "/proc/nope" in captured.err
    assert "Traceback" not in captured.err
    assert "checks:" not in captured.out and "runs failed" not in captured.out  # nothing was run
    assert "verdict" not in captured.out


@pytest.mark.parametrize("option, name", [("--json", "r.json"), ("--save", "s.h5"), ("--plot", "p.png")])
def test_outputs_into_a_read_only_folder_are_refused_before_the_run(read_only_folder, capsys, option, name):
    assert cli.main([*RUN, option, str(read_only_folder / name)]) == 2
    captured = capsys.readouterr()
    assert option in captured.err and "not writable" in captured.err
    assert "Result(" not in captured.out


def test_dem_outputs_onto_one_file_are_refused(tmp_path, capsys):
    target = str(tmp_path / "t.json")
    assert cli.main(["dem", "transient", "--out", str(tmp_path), "--json", target, "--npz", target]) == 2
    assert "same file" in capsys.readouterr().err


# --- a full disk (items 7 and 17) ------------------------------------------------------------------


def test_save_on_a_full_disk_exits_4_and_keeps_the_json(tmp_path, tiny_disk, capsys):
    summary = tmp_path / "r.json"
    status = cli.main(["run", "--N", "101", "--t-end", "1", "--no-progress", "--times", *map(str, range(2)),
                       "--json", str(summary), "--save", str(tiny_disk / "s.h5")])
    captured = capsys.readouterr()
    assert status == 4
    assert "--save" in captured.err and "No space left" in captured.err and "Traceback" not in captured.err
    data = json_at(summary)
    assert data["reason"] == "reached t_end" and data["not_written"] == {"save": "No space left on device"}
    assert list(tiny_disk.iterdir()) == []  # no half-written file, no temporary file


def test_save_failing_mid_run_exits_4_and_keeps_the_json(tmp_path, capsys, monkeypatch):
    """The same in process (a full disk as h5py reports it, after the first frame)."""
    from pde import FileStorage

    original, calls = FileStorage.append, []

    def full(self, *args, **kwargs):
        calls.append(1)
        if len(calls) > 1:
            raise RuntimeError("Can't write data (file write failed: errno = 28, error message = "
                               "'No space left on device')")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(FileStorage, "append", full)
    summary, save = tmp_path / "r.json", tmp_path / "s.h5"
    status = cli.main([*RUN, "--times", "0", "0.05", "0.1", "--json", str(summary), "--save", str(save)])
    assert status == 4
    assert "No space left" in capsys.readouterr().err
    assert json_at(summary)["t_final"] == 0.1
    assert not save.exists() and leftovers(tmp_path) == []


def test_plot_on_a_full_disk_leaves_no_partial_png(tmp_path, capsys, monkeypatch):
    from matplotlib.figure import Figure

    def full(self, fname, *args, **kwargs):
        Path(fname).write_bytes(b"\x89PNG")  # the first bytes, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full)
    summary, plot = tmp_path / "r.json", tmp_path / "p.png"
    assert cli.main([*RUN, "--json", str(summary), "--plot", str(plot)]) == 4
    assert "No space left" in capsys.readouterr().err
    assert not plot.exists() and leftovers(tmp_path) == []
    assert json_at(summary)["reason"] == "reached t_end"


# --- interrupts while the outputs are written (items 5 and 17) -------------------------------------


def test_interrupt_while_the_movie_renders_keeps_the_json(tmp_path, capsys, monkeypatch):
    from icidr_pde.movies import frames as movies

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(movies, "write_movie", interrupted)
    summary, save, movie = tmp_path / "r.json", tmp_path / "s.h5", tmp_path / "m.gif"
    status = cli.main([*RUN, "--json", str(summary), "--save", str(save), "--movie", str(movie), "--frame-dt", "0.05"])
    captured = capsys.readouterr()
    assert status == 130
    assert json_at(summary)["reason"] == "reached t_end"
    assert save.is_file() and not movie.exists()
    assert "--movie" in captured.err and "interrupted" in captured.err


def test_json_is_written_before_the_movie_renders(tmp_path, monkeypatch):
    from icidr_pde.movies import frames as movies

    seen = []
    original = movies.write_movie
    monkeypatch.setattr(movies, "write_movie",
                        lambda *a, **k: (seen.append((tmp_path / "r.json").is_file()), original(*a, **k))[1])
    assert cli.main([*RUN, "--json", str(tmp_path / "r.json"), "--movie", str(tmp_path / "m.gif"),
                     "--frame-dt", "0.05"]) == 0
    assert seen == [True] and (tmp_path / "m.gif").is_file()


def test_sigint_while_the_plot_renders_keeps_the_json_and_exits_130(tmp_path, capsys, monkeypatch):
    from icidr_pde import plotting

    def interrupted(result, path):
        raise KeyboardInterrupt

    monkeypatch.setattr(plotting, "plot_result", interrupted)
    summary, plot = tmp_path / "r.json", tmp_path / "p.png"
    assert cli.main([*RUN, "--json", str(summary), "--plot", str(plot)]) == 130
    captured = capsys.readouterr()
    assert "interrupted" in captured.err and "--plot" in captured.err and "Traceback" not in captured.err
    assert "Result(" in captured.out  # what was computed is reported
    assert json_at(summary)["reason"] == "reached t_end" and not plot.exists()


@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_while_the_plot_renders_exits_with_its_status(tmp_path, sig, status):
    """A real signal in a separate process: SIGTERM had the default handler there (killed, -15)."""
    code = (f"import os, sys, time\nfrom icidr_pde import cli, plotting\n"
            f"def slow(result, path):\n    os.kill(os.getpid(), {int(sig)})\n    time.sleep(60)\n"
            f"plotting.plot_result = slow\n"
            f"sys.exit(cli.main({RUN + ['--json', 'r.json', '--plot', 'p.png']!r}))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, timeout=600)
    assert done.returncode == status, done.stderr.decode()
    assert b"interrupted" in done.stderr and b"Traceback" not in done.stderr
    assert json_at(tmp_path / "r.json")["reason"] == "reached t_end"
    assert not (tmp_path / "p.png").exists() and leftovers(tmp_path) == []


def test_native_interrupt_keeps_the_outputs_cvode_returned(monkeypatch):
    """Ctrl-C is seen once CVODE returns, before Python counted that call's outputs: the run
    reported 'interrupted at t = 0' and dropped the states the driver had written."""
    from icidr_pde.api import run
    from icidr_pde.native import NativeProblem, NativeUnavailable
    from icidr_pde.native_case import FdCase

    try:
        FdCase("icidr", "shear", 9).problem()
    except NativeUnavailable:
        pytest.skip("no native engine here")
    original = NativeProblem.advance

    def interrupted_on_return(self, *args):
        original(self, *args)
        raise KeyboardInterrupt

    monkeypatch.setattr(NativeProblem, "advance", interrupted_on_return)
    res = run("icidr", "shear", 21, 10.0, ["0", "10"], engine="native")
    assert res.settings["engine"] == "native"
    assert res.reason.startswith("interrupted") and res.t_final > 0
    assert res.max_w_t.size > 0 and res.max_w_t[-1] < res.t_final  # CVODE's last step, past the last output
    assert np.all(np.isfinite(res.max_w_series)) and res.n_steps > 0
    assert res.reason == f"interrupted at t = {res.t_final:.6g}"


# --- the writer itself -----------------------------------------------------------------------------


def test_interrupted_writer_leaves_the_old_file_and_no_temporary(tmp_path):
    from icidr_pde.outputs import write_atomically

    target = tmp_path / "r.json"
    target.write_text("old")

    def write(fh):
        fh.write("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically(target, write)
    assert target.read_text() == "old" and leftovers(tmp_path) == []


def test_a_directory_is_never_replaced(tmp_path):
    from icidr_pde.outputs import write_atomically

    (tmp_path / "d").mkdir()
    with pytest.raises(IsADirectoryError):
        write_atomically(tmp_path / "d", lambda fh: fh.write("x"))
    assert (tmp_path / "d").is_dir()


@pytest.mark.parametrize("argv", [_stability_argv("--json", "s.json"),
                                  ["law", "check", "icidr", "--no-curves", "--json", "r.json"]],
                         ids=["stability", "law-check"])
def test_other_subcommands_exit_4_when_an_output_cannot_be_written(tmp_path, capsys, monkeypatch, argv):
    """The README's 4: a full disk at the end of `stability` or `law check` was an OSError traceback."""
    from icidr_pde import outputs

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(outputs.os, "replace", full)
    assert cli.main(argv) == 4
    err = capsys.readouterr().err
    assert "could not write" in err and argv[-1] in err and "No space left on device" in err
    assert list(tmp_path.iterdir()) == []
