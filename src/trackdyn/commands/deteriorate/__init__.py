"""`trackdyn deteriorate`: the deterioration scenario run section by section on Dask.

The scenario file (`trackdyn.commands.deteriorate.scenario`), the sections list
(`trackdyn.commands.deteriorate.sections`), the output files
(`trackdyn.commands.deteriorate.outputs`) and figures
(`trackdyn.plots.deteriorate`); the runs are `trackdyn.deterioration.runs`.
"""

from __future__ import annotations

import dataclasses

from trackdyn.commands.compiling import say_if_compiling
from trackdyn.commands.drawing import helper
from trackdyn.commands.geometry_notes import PREFIX, geometry_notes
from trackdyn.commands.staging import Record, output_folder
from trackdyn.commands.tables import deterioration_table, forecast_table, frame_table
from trackdyn.errors import require_workers
from trackdyn.progress import note
from trackdyn.provenance import recorded


@recorded
def deteriorate(
    scenario, out, overwrite: bool, workers, scheduler, console, section_figures=None
) -> None:
    """Predict the deterioration of every section; write its Datasets, tables and figures.

    Parameters
    ----------
    scenario : path, optional
        Deterioration scenario TOML file; None: the built-in example.
    out : Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    workers : int, optional
        Worker processes (default: one per core; this process alone for few and short
        sections, `trackdyn.deterioration.runs.in_process`).
    scheduler : str, optional
        Address of a running Dask scheduler.
    console : rich.console.Console
        Where the summary table is shown.
    section_figures : int, optional
        Sections whose own figures are drawn: all of a line of at most this many, else
        this many, the most urgent (`trackdyn.commands.deteriorate.outputs.figured`);
        default `trackdyn.commands.deteriorate.outputs.FIGURED_SECTIONS`.
    """
    from trackdyn.commands.deteriorate.outputs import (
        FIGURED_SECTIONS,
        SECTION_FIGURES,
        figured,
        summary,
        write_outputs,
    )
    from trackdyn.commands.deteriorate.scenario import load_deterioration
    from trackdyn.commands.deteriorate.sections import section_tasks
    from trackdyn.deterioration.runs import in_process, run_sections

    spec, base = load_deterioration(scenario)
    require_workers(workers)
    limit = FIGURED_SECTIONS if section_figures is None else section_figures
    tasks = section_tasks(spec, base)
    serial = in_process(tasks, workers, scheduler)
    if serial:
        tasks = [dataclasses.replace(t, progress=True) for t in tasks]
    title = f"trackdyn deteriorate: {spec.run.model}, {len(tasks)} section(s)"
    record = Record(title, {"scenario": scenario}, spec.model_dump(mode="json"))
    plan = None
    if spec.forecast is not None:  # sampled (and refused if wrong) before anything runs
        from trackdyn.commands.deteriorate.forecast import plan_forecast

        plan = plan_forecast(spec, base, tasks)
    figures = len(SECTION_FIGURES) * min(len(tasks), limit)
    with output_folder(out, "deteriorate", overwrite, record) as stage, helper(figures) as pool:
        say_if_compiling("deteriorate", scheduler)
        datasets = run_sections(tasks, workers=workers, scheduler=scheduler, progress=not serial)
        for ds in datasets:
            attrs = ds.attrs.items()
            told = ((k.removeprefix(PREFIX), v) for k, v in attrs if k.startswith(PREFIX))
            geometry_notes(told, f"section {ds.attrs['section']}")
        sections = summary(datasets)
        record.headline = {"sections": sections.to_dict(orient="records")}
        shown = figured(sections, limit)
        if len(shown) < len(datasets):
            which = f"those that reach the threshold first ({_listed(shown)})" if shown else "none"
            note(f"figures of {len(shown)} of the {len(datasets)} sections: {which}; "
                 f"--section-figures {len(datasets)} draws them all")  # fmt: skip
        files = write_outputs(datasets, stage, pool, shown)
        forecast = table = None
        if plan is not None:
            forecast, table = _forecast(plan, tasks, workers, scheduler, stage, pool, files,
                                        record, shown)  # fmt: skip
        deferred = None
        if spec.plan is not None:
            deferred = _plan(spec, tasks, datasets, forecast, workers, scheduler, stage, files,
                             record)  # fmt: skip
    title = f"Deterioration, {spec.run.model}: {len(datasets)} section(s)"
    console.print(deterioration_table(sections, title))
    if plan is not None:
        console.print(forecast_table(table, f"First tamping, {plan.members.count} members"))
    if deferred is not None and len(deferred):
        console.print(frame_table(deferred, "Deferred by the plan's cap"))
    note(f"wrote {len(files)} files (deterioration_*.nc, CSV tables, figures) to {out}")
    note("\n".join(record.lines()), 2)


def _listed(names, shown: int = 6) -> str:
    """``names`` joined, the first ``shown`` of a longer list and how many more."""
    more = f", and {len(names) - shown} more" if len(names) > shown else ""
    return ", ".join(names[:shown]) + more


def _forecast(plan, tasks, workers, scheduler, stage, pool, files, record, shown):
    """Run the planned ensemble, write its files into ``stage`` (the figures of the
    sections ``shown`` names, drawn by ``pool``'s helper; their names added to ``files``)
    and its headline into ``record``; return ``forecast.csv``'s table."""
    from trackdyn.commands.deteriorate.forecast import headline, run_forecast, write_forecast

    forecast = run_forecast(plan, tasks, workers=workers, scheduler=scheduler, progress=True)
    names = [t.section.name for t in tasks]
    written, table = write_forecast(forecast, names, stage, pool, shown)
    files += written
    record.headline["forecast_first_tamping_mgt"] = headline(table)
    return forecast, table


def _plan(spec, tasks, datasets, forecast, workers, scheduler, stage, files, record):
    """Make the ``[plan]``, run it, write its files into ``stage`` (their names added to
    ``files``) and its headline into ``record``; return what its cap deferred."""
    from trackdyn.commands.deteriorate.plan import run_plan, write_plan

    result = run_plan(spec, tasks, datasets, forecast, workers=workers, scheduler=scheduler)
    plan, lines, _, rules = result
    written, deferred = write_plan(spec, result, stage)
    files += written
    record.headline["plan"] = {
        "stretches": len(plan.stretches),
        "tamped_m": sum(s.length(lines[s.section]) for s in plan.stretches),
        "deferred": len(plan.deferred),
        "years": rules.years,
    }
    return deferred
