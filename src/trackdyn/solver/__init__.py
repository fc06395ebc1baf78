"""The solvers, behind one entry point: `solve` runs `Problem` s and returns their arrays.

``"central"`` is the compiled central-difference scheme on the Winkler track
(`trackdyn.solver.central`), which advances runs of one model side by side in the vector
lanes (their operations in `trackdyn.lanewise`); ``"reference"`` is scipy's DOP853 at
tight tolerance (`trackdyn.solver.reference`), slow, to check a case; ``"discrete"`` the
same central scheme for the vehicle with the rails, pads and sleepers of the discrete
track (`trackdyn.solver.discrete`), a run per thread. Which one a run takes is
`trackdyn.options.RunOptions.integrator`.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba

from trackdyn.solver import central, discrete, reference
from trackdyn.solver.statics import OUTPUTS, Problem

__all__ = ["OUTPUTS", "SOLVERS", "Problem", "solve"]

SOLVERS = ("central", "reference", "discrete")


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
    solver : {"central", "reference", "discrete"}
        Which solver (`SOLVERS`; ``"discrete"``: the problems' inputs are discrete tracks,
        and each run returns every output and the ballast's peaks).
    newton_max_iter : int
        Newton iterations of the wedge friction allowed per step (central scheme).
    advanced : callable, optional
        Called with the number of steps done, as they are done.
    keep : sequence of str
        The `OUTPUTS` returned (the central scheme does not store the others).
    """
    if solver == "discrete":  # one run per thread (the compiled loop releases the GIL)
        with ThreadPoolExecutor(max(1, min(len(problems), numba.get_num_threads()))) as pool:
            return list(pool.map(lambda p: discrete.solve(p, newton_max_iter, advanced),
                                 problems))  # fmt: skip
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
