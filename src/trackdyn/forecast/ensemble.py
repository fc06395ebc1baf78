"""An ensemble forecast: the members of each section run as sections run.

Each member is the section's `SectionTask` with its own law parameters, rate-field seed and
horizon (`trackdyn.forecast.spread.Members`); all members of all sections go through
`trackdyn.deterioration.runs.run_sections` together, so that the members of one section
(one vehicle model) fill the solver's vector lanes together. A member with nothing varied
is the deterministic run, to the bit.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from trackdyn.deterioration.runs import SectionTask, run_sections
from trackdyn.forecast.spread import Growth, Members


def member_tasks(task: SectionTask, members: Members, growth: Growth | None = None,
                 horizon_years: float | None = None) -> list[SectionTask]:  # fmt: skip
    """The tasks of ``task``'s members.

    Parameters
    ----------
    task : SectionTask
        The section's deterministic task.
    members : Members
        The members' samples.
    growth : Growth, optional
        Traffic growth; with ``horizon_years``, each member's horizon is the tonnage its
        traffic carries in those years (`Growth.mgt_by`).
    horizon_years : float, optional
        Horizon [year]; None: every member runs to the task's ``total_mgt``.

    Returns
    -------
    list of SectionTask
        One per member, named ``<section> member <m>``: on its drawn field
        (`Members.field`) where the members have drawn fields; else a calibrated rate
        field given in the options (``rate_factor``) stays as given, otherwise each member
        draws its own (seed: the section's followed by ``m + 1``).
    """
    out = []
    for m in range(members.count):
        update: dict = {}
        if members.fields is not None:
            update["rate_factor"] = members.field(m)
        elif members.fresh_fields and task.options.rate_factor is None:
            update["seed"] = (*np.atleast_1d(task.options.seed).tolist(), m + 1)
        if growth is not None and horizon_years is not None:
            update["total_mgt"] = float(growth.mgt_by(horizon_years, members.growth[m]))
        options = task.options.model_copy(update=update)
        law = dataclasses.replace(task.law, **members.overrides(m))
        section = dataclasses.replace(task.section, name=f"{task.section.name} member {m}")
        out.append(dataclasses.replace(task, section=section, law=law, options=options,
                                       progress=False))  # fmt: skip
    return out


def run_ensemble(tasks, members: Members, *, growth=None, horizon_years=None, workers=None,
                 scheduler=None, progress=False) -> list[list]:  # fmt: skip
    """Run every member of every section's task.

    Parameters
    ----------
    tasks : list of SectionTask
        The sections' deterministic tasks.
    members : Members
        The members' samples (the same for every section).
    growth, horizon_years
        As `member_tasks`.
    workers, scheduler, progress
        As `trackdyn.deterioration.runs.run_sections`.

    Returns
    -------
    list of list of xarray.Dataset
        Per section, its members' results in member order.
    """
    each = [member_tasks(t, members, growth, horizon_years) for t in tasks]
    flat = [t for member in each for t in member]
    done = run_sections(flat, workers=workers, scheduler=scheduler, progress=progress)
    return [done[i * members.count : (i + 1) * members.count] for i in range(len(tasks))]
