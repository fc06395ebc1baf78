"""The note of a first run that compiles the solver: when the cache is cold, and only then."""

import ast
import io
import os
import sys
from pathlib import Path

import trackdyn
from trackdyn.commands import compiling
from trackdyn.commands.compiling import KERNELS, SECONDS, cache_folder, compiling_note
from trackdyn.progress import set_verbosity

PACKAGE = Path(trackdyn.__file__).parent
VERSION = f"py{sys.version_info.major}{sys.version_info.minor}"


def index_file(cache: Path, file: str, function: str) -> Path:
    """Where numba writes the index of ``function`` (line number made up: any matches)."""
    source = PACKAGE / file
    folder = cache / cache_folder(source).name
    folder.mkdir(parents=True, exist_ok=True)
    return folder / f"{source.stem}.{function}-1.{VERSION}.nbi"


def test_every_kernel_named_is_a_compiled_function_of_its_file():
    # a renamed kernel would leave the note on for good: each name must be a jitted def
    for kernels in KERNELS.values():
        for file, function in kernels:
            tree = ast.parse((PACKAGE / file).read_text())
            (found,) = [n for n in tree.body if getattr(n, "name", None) == function]
            decorators = [ast.unparse(d) for d in found.decorator_list]
            assert any(d.startswith("njit") for d in decorators), (file, function)
    assert set(SECONDS) == set(KERNELS)


def test_the_cache_folder_is_numbas():
    # where numba's cache of a kernel says it keeps it (under this session's NUMBA_CACHE_DIR)
    from trackdyn.beam import railseat
    from trackdyn.solver import kernel

    for module, function in ((kernel, "advance"), (railseat, "_window_solve")):
        kept = Path(getattr(module, function)._cache.cache_path)
        assert kept == cache_folder(Path(module.__file__)), function


def test_note_when_an_index_is_missing_or_older_than_its_source(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert compiling_note("run") == "compiling the solver once (about 7 s; cached for later runs)"
    assert compiling_note("track") is None  # compiles little
    ((file, function),) = KERNELS["run"]
    index = index_file(tmp_path, file, function)
    index.write_bytes(b"")
    assert compiling_note("run") is None
    changed = (PACKAGE / file).stat().st_mtime
    os.utime(index, (changed - 10, changed - 10))  # the source edited since: numba recompiles
    assert compiling_note("run") is not None
    for file, function in KERNELS["deteriorate"][:1]:  # one of its two kernels cached
        index_file(tmp_path, file, function).write_bytes(b"")
    assert compiling_note("deteriorate") is not None


def shown_with_a_bar(monkeypatch, level: int, terminal: bool, scheduler=None) -> str:
    """What stderr shows of the note said for a study, then a bar of 2 runs moved once."""
    from rich.console import Console

    from trackdyn import progress

    screen = io.StringIO()
    console = Console(file=screen, force_terminal=terminal, width=200, color_system=None)
    monkeypatch.setattr(progress, "_stderr", lambda: console)
    set_verbosity(level)
    try:
        compiling.say_if_compiling("study", scheduler)
        with progress.progress_bar(True, 2, "runs") as bar:
            bar.advance()
    finally:
        set_verbosity(1)
    return screen.getvalue()


NOTE = "compiling the solver once (about 30 s; cached for later runs)"


def test_the_note_comes_with_the_bar_on_a_terminal_unless_quiet(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert f"runs, {NOTE}" in shown_with_a_bar(monkeypatch, 1, terminal=True)
    assert NOTE not in shown_with_a_bar(monkeypatch, 0, terminal=True)  # -q
    assert shown_with_a_bar(monkeypatch, 1, terminal=False) == ""  # a log: nothing
    with_scheduler = shown_with_a_bar(monkeypatch, 1, True, scheduler="tcp://10.0.0.5:8786")
    assert "runs" in with_scheduler and NOTE not in with_scheduler  # its workers' own cache


def test_a_refused_input_leaves_one_line_on_a_cold_cache(monkeypatch, tmp_path):
    # the note waits for the bar, so an input refused before any run is one line on stderr
    from typer.testing import CliRunner

    from trackdyn.cli import app

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    Path("bad.toml").write_text("[loop]\ntotal_mgt = 0.1\nsegment_length_m = 1e6\n")
    result = CliRunner().invoke(app, ["deteriorate", "bad.toml", "--out", "out"])
    assert result.exit_code == 2, result.output
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
