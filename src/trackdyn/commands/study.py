"""Files of a study: the table, the Dataset and the figures its kind calls for."""

from __future__ import annotations

from trackdyn.commands import plots
from trackdyn.io import write_netcdf


def write_study(table, ds, study, folder) -> list[str]:
    """Write ``study.nc``, ``study.csv`` and the figures into ``folder``; return the names.

    A matrix study draws ``study_cases.png``, a one-at-a-time sensitivity study
    ``tornado.png``, a speed study ``speed_sweep.png``; every study with a successful run
    draws ``spectra.png``.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run (`trackdyn.studies.runner.gather`).
    ds : xarray.Dataset
        The same runs with their spectra.
    study : Study
        The study (its ``kind``).
    folder : Path
        Output folder.
    """
    write_netcdf(ds, folder / "study.nc")
    table.to_csv(folder / "study.csv", index=False, float_format="%.4g")
    names = ["study.nc", "study.csv"]
    if not (table["error"] == "").any():
        return names
    figures = {
        "matrix": ("study_cases.png", plots.study_matrix),
        "speed": ("speed_sweep.png", plots.speed_sweep),
    }
    if not study.sensitivity.grid:
        figures["sensitivity"] = ("tornado.png", plots.tornado)
    if study.kind in figures:
        name, draw = figures[study.kind]
        draw(table, folder / name)
        names.append(name)
    plots.spectra(table, ds, folder / "spectra.png")
    return [*names, "spectra.png"]
