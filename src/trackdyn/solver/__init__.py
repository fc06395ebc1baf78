"""The solvers, behind one entry point: `solve` runs `Problem` s and returns their arrays.

``"central"`` is the compiled central-difference scheme (`trackdyn.solver.central`), which
advances runs of one model side by side in the vector lanes (their operations in
`trackdyn.lanewise`); ``"reference"`` is scipy's
DOP853 at tight tolerance (`trackdyn.solver.reference`), slow, to check a case.
"""

from __future__ import annotations

from trackdyn.solver import central, reference
from trackdyn.solver.statics import OUTPUTS, Problem

__all__ = ["OUTPUTS", "SOLVERS", "Problem", "solve"]

SOLVERS = ("central", "reference")


def solve(problems, solver: str = "central", *, newton_max_iter: int = 50, advanced=None,
          keep=OUTPUTS):  # fmt: skip
    """Integrate runs; per run a dict of the `OUTPUTS` arrays (those in ``keep``) or the error
    that stopped it.

    Parameters
    ----------
    problems : list of Problem
        The runs. With ``"central"``, runs of the same model (name) and kind of contact
        go through one compiled call per block of steps; results do not depend on the
        grouping.
    solver : {"central", "reference"}
        Which solver.
    newton_max_iter : int
        Newton iterations of the wedge friction allowed per step (central scheme).
    advanced : callable, optional
        Called with the number of steps done, as they are done.
    keep : sequence of str
        The `OUTPUTS` returned (the central scheme does not store the others).
    """
    if solver == "reference":
        solved = [reference.solve(p, advanced) for p in problems]
        return [r if isinstance(r, Exception) else {k: r[k] for k in keep} for r in solved]
    groups: dict = {}
    for i, p in enumerate(problems):
        groups.setdefault((p.model.name, p.inputs.grid.size), []).append(i)
    results: list = [None] * len(problems)
    for index in groups.values():
        batch = central.solve([problems[i] for i in index], newton_max_iter, advanced, keep)
        for i, res in zip(index, batch, strict=True):
            results[i] = res
    return results
