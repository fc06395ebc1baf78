"""`trackdyn example`: the shipped example inputs written into a folder, ready to run.

Each example is a set of files shipped in the package (``trackdyn/examples`` and the
built-in section of ``trackdyn/data``), written under the names its scenario uses.
"""

from __future__ import annotations

import shutil
from importlib.resources import files

from trackdyn.commands.staging import output_folder
from trackdyn.errors import unknown

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
        "three studies: the 2-DOF scenario matrix, a parameter variation, a speed sweep",
        {
            "matrix-2dof.toml": "examples/matrix-2dof.toml",
            "sensitivity.toml": "examples/sensitivity.toml",
            "speed.toml": "examples/speed.toml",
        },
        "trackdyn study {to}/sensitivity.toml --out study-out",
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
"""Example name -> (what it is, {file written: file in the package}, how to run it)."""


def listing() -> str:
    """The examples, one a line: name and what it is."""
    return "\n".join(f"{name:12} {text}" for name, (text, _, _) in EXAMPLES.items())


def write_example(name: str, to, overwrite: bool = False) -> tuple[list[str], str]:
    """Write the files of example ``name`` into the folder ``to``.

    Parameters
    ----------
    name : str
        A key of `EXAMPLES`.
    to : str or Path
        Folder to write into (created if missing).
    overwrite : bool
        Replace another command's outputs in ``to``.

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
    package = files("trackdyn")
    with output_folder(to, "example", overwrite, flag="--to") as stage:
        for target, source in sources.items():
            with package.joinpath(source).open("rb") as src, open(stage / target, "wb") as dst:
                shutil.copyfileobj(src, dst)
    return list(sources), command.format(to=to)
