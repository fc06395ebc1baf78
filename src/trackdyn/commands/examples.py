"""`trackdyn example`: the shipped example inputs written into a folder, ready to run.

Each example is a set of files shipped in the package (``trackdyn/examples`` and the
built-in section of ``trackdyn/data``), written under the names its scenario uses; files of
those names already in the folder are refused unless ``--overwrite``. The folder gets no
manifest: it holds inputs, which the user edits, not a command's outputs.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from importlib.resources import files
from pathlib import Path

from trackdyn.errors import TrackdynInputError, unknown

_TRACK = {
    "geometry.csv": "data/example_geometry.csv",
    "supports.csv": "data/example_supports.csv",
}
_ZONES = {"zones.csv": "data/example_zones.csv"}

EXAMPLES: dict[str, tuple[str, dict[str, str], str]] = {
    "run": (
        "a run scenario: the loaded wagon, 11-DOF, 60 km/h over the 1 km example section",
        {"run.toml": "examples/run.toml", **_TRACK},
        "trackdyn run {to}/run.toml --out run-out",
    ),
    "deteriorate": (
        "a deterioration scenario: 50 MGT of coal traffic over the example section, zones",
        {"deteriorate.toml": "examples/deteriorate.toml", **_TRACK, **_ZONES},
        "trackdyn deteriorate {to}/deteriorate.toml --out deteriorate-out",
    ),
    "sections": (
        "a sections list for deteriorate: two sections, 10 MGT",
        {
            "sections.toml": "examples/sections.toml",
            "sections.csv": "examples/sections.csv",
            **_TRACK,
            **_ZONES,
        },
        "trackdyn deteriorate {to}/sections.toml --out sections-out",
    ),
    "study": (
        "three studies, each run by trackdyn study: matrix-2dof.toml (the 2-DOF scenario "
        "matrix), sensitivity.toml (a parameter variation), speed.toml (a speed sweep)",
        {
            "matrix-2dof.toml": "examples/matrix-2dof.toml",
            "sensitivity.toml": "examples/sensitivity.toml",
            "speed.toml": "examples/speed.toml",
        },
        "trackdyn study {to}/matrix-2dof.toml --out matrix-out\n"
        "trackdyn study {to}/sensitivity.toml --out sensitivity-out\n"
        "trackdyn study {to}/speed.toml --out speed-out",
    ),
    "interventions": (
        "an interventions study: the example section with tamping, four alternatives, 50 MGT",
        {
            "interventions.toml": "examples/interventions.toml",
            "maintained.toml": "examples/maintained.toml",
            **_TRACK,
            **_ZONES,
        },
        "trackdyn study {to}/interventions.toml --out interventions-out",
    ),
    "survey": (
        "a run on a recording car's file: asymmetric-chord versines in decreasing km, a gap",
        {
            "survey.toml": "examples/survey/survey.toml",
            "versine.csv": "examples/survey/versine.csv",
            "supports.csv": "data/example_supports.csv",
        },
        "trackdyn run {to}/survey.toml --out survey-out",
    ),
    "stiffness": (
        "a run on a measured track stiffness per rail at 100 kN, every metre (RSMV-like)",
        {
            "stiffness.toml": "examples/stiffness/stiffness.toml",
            "stiffness.csv": "examples/stiffness/stiffness.csv",
            "geometry.csv": "data/example_geometry.csv",
        },
        "trackdyn run {to}/stiffness.toml --out stiffness-out",
    ),
    "calibration": (
        "a calibration with three synthetic surveys of a 200 m section",
        {
            "calibration.toml": "examples/calibration/calibration.toml",
            "supports.csv": "examples/calibration/supports.csv",
            **{f"survey_{k}.csv": f"examples/calibration/survey_{k}.csv" for k in (1, 2, 3)},
        },
        "trackdyn calibrate {to}/calibration.toml --out calibration-out",
    ),
}
"""Example name -> (what it is, {file written: file in the package}, how to run it: a
command a line, one for each scenario of the example)."""


def listing() -> str:
    """The examples, one a line: name and what it is."""
    width = max(map(len, EXAMPLES))
    return "\n".join(f"{name:{width}}  {text}" for name, (text, _, _) in EXAMPLES.items())


def example_file(name: str, target: str) -> Path:
    """The file of the package that example ``name`` writes as ``target``.

    Parameters
    ----------
    name : str
        A key of `EXAMPLES`.
    target : str
        A file the example writes (``calibration.toml``).
    """
    return Path(str(files("trackdyn").joinpath(EXAMPLES[name][1][target])))


def write_example(name: str, to, overwrite: bool = False) -> tuple[list[str], str]:
    """Write the files of example ``name`` into the folder ``to``: all of them or, if one
    cannot be written, none.

    A file of the example's names already in ``to`` (an edited ``run.toml``, another
    section's ``geometry.csv``) is refused unless ``overwrite``; other files there are left
    alone.

    Parameters
    ----------
    name : str
        A key of `EXAMPLES`.
    to : str or Path
        Folder to write into (created if missing).
    overwrite : bool
        Replace files of the example's names in ``to``.

    Returns
    -------
    names : list of str
        The files written.
    command : str
        The command that runs the example.
    """
    if name not in EXAMPLES:
        raise unknown("example", name, EXAMPLES)
    _, sources, command = EXAMPLES[name]
    if not str(to).strip():
        raise TrackdynInputError("--to is empty: name a folder")
    folder = Path(to)
    if folder.exists() and not folder.is_dir():
        raise TrackdynInputError(f"--to {to}: exists and is not a folder")
    there = [target for target in sources if (folder / target).exists()]
    if there and not overwrite:
        raise TrackdynInputError(
            f"--to {to}: {', '.join(there)} already there; choose another folder or give "
            "--overwrite to replace them"
        )
    package = files("trackdyn")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix=f".staging-{os.getpid()}-", dir=folder) as tmp:
            stage = Path(tmp)
            for target, source in sources.items():
                with package.joinpath(source).open("rb") as src, open(stage / target, "wb") as dst:
                    shutil.copyfileobj(src, dst)
            for target in sources:
                os.replace(stage / target, folder / target)
    except OSError as exc:
        raise TrackdynInputError(f"--to {to}: cannot write there ({exc.strerror})") from None
    return list(sources), command.format(to=to)
