"""The scheme's matrices of a run (`StepMatrices`: the step's sparse rows, the wedges'
Newton inverses, the contacts), its start state, and the time step's limit.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4, eqs
5.15-5.18.

Bathe, K.J. (1996). Finite Element Procedures. Prentice Hall, Englewood Cliffs, §9.2.1
(the central difference method and its stability limit Δt < 2/ω_max).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from trackdyn.solver.statics import (
    Problem,
    contact_table,
    start_path,
    wedge_forces,
    wedge_table,
)


def start_state(p: Problem, wedge) -> np.ndarray:
    """``z = [q0, q-1]`` for a start on the static path (`start_path`).

    The acceleration follows from the equations of motion (springs and track balance at
    static equilibrium, leaving damping and friction): ``q-1 = q0 - dt v0 + dt²/2 a0``, a
    start that keeps the scheme second-order accurate.
    """
    m, dt = p.model, p.dt
    q0, v0 = start_path(p)
    friction = wedge_forces(wedge, m.Dw @ q0, m.Dw @ v0)
    a0 = -(m.C @ v0 + m.Dw.T @ friction) / np.diag(m.M)
    return np.r_[q0, q0 - dt * v0 + 0.5 * dt**2 * a0]


def _sparse_rows(D):
    """Column indices of the nonzeros of each row of the matrices ``D`` (runs, rows,
    columns), zero-padded, and the runs' values there (runs, rows, width).

    The models' matrices are mostly zeros (``A`` is block diagonal: no damper crosses the
    secondary suspension), so the loop runs over nonzeros only; the columns are those
    where any run has a nonzero (the runs of a batch share them).
    """
    nonzero = (D != 0).any(axis=0)
    width = max(1, int(nonzero.sum(axis=1).max())) if nonzero.size else 1
    idx = np.zeros((D.shape[1], width), np.int64)
    val = np.zeros((D.shape[0], D.shape[1], width))
    for r, row in enumerate(nonzero):
        nz = np.flatnonzero(row)
        idx[r, : nz.size], val[:, r, : nz.size] = nz, D[:, r, nz]
    return idx, val


class StepMatrices(NamedTuple):
    """Constant arrays of the scheme (`step_matrices`), in the order `advance` takes them."""

    p_idx: np.ndarray
    p_val: np.ndarray
    gc_idx: np.ndarray
    gc_val: np.ndarray
    gw_idx: np.ndarray
    gw_val: np.ndarray
    dc_idx: np.ndarray
    dc_val: np.ndarray
    dw_idx: np.ndarray
    dw_val: np.ndarray
    ds_idx: np.ndarray
    ds_val: np.ndarray
    H: np.ndarray
    jinv: np.ndarray
    wedge: np.ndarray
    contact: np.ndarray


def _scheme(model, dt) -> tuple[list, list]:
    """The dense matrices of `step_matrices` (``P``, ``Gc^T``, ``Gw^T``, ``Dc``, ``Dw``,
    ``Ds``) and its other arrays (``H``, the inverses, the wedge and contact tables)."""
    M, C, K, Dc, Dw = model.M, model.C, model.K, model.Dc, model.Dw
    A = M / dt**2 + C / (2 * dt)
    Ainv = np.linalg.inv(A)
    P = np.hstack([Ainv @ (2 * M / dt**2 - K), -Ainv @ (M / dt**2 - C / (2 * dt))])
    Gw = Ainv @ Dw.T
    H = Dw @ Gw / (2 * dt)
    wedge = wedge_table(model)
    c_slope = wedge[:, 3]
    nw = Dw.shape[0]
    jinv = np.empty((2**nw, nw, nw))
    for mask in range(2**nw):
        stick = np.array([(mask >> w) & 1 for w in range(nw)], dtype=float)
        jinv[mask] = np.linalg.inv(np.eye(nw) + H * (c_slope * stick)[None, :])
    dense = [P, (Ainv @ Dc.T).T, Gw.T, Dc, Dw, model.Ds]
    return dense, [H, jinv, wedge, contact_table(model)]


def run_matrices(models, dts) -> StepMatrices:
    """`StepMatrices` of runs of one model (`step_matrices` of each): the sparse rows'
    indices shared, every other array with a leading run axis."""
    dense, rest = zip(*(_scheme(m, dt) for m, dt in zip(models, dts, strict=True)), strict=True)
    sparse = [_sparse_rows(np.stack(d)) for d in zip(*dense, strict=True)]
    pairs = (a for pair in sparse for a in pair)
    return StepMatrices._make([*pairs, *(np.stack(r) for r in zip(*rest, strict=True))])


def step_matrices(model, dt) -> StepMatrices:
    """Constant arrays of the scheme for `advance`, from a `Model` and the step [s].

    The sparse rows (`_sparse_rows`) of ``P = [A^-1 (2M/Δt² - K), -A^-1 (M/Δt² - C/(2Δt))]``
    acting on ``[q0, q-1]``, of ``Gc^T`` and ``Gw^T`` with ``Gc = A^-1 Dc^T`` and
    ``Gw = A^-1 Dw^T``, and of ``Dc``, ``Dw`` and ``Ds``; ``H``; the inverses of
    ``I + H diag(C_slope·stick)`` for every stick/slip combination; per wedge
    ``x_ss [m]``, the slip force per unit spring
    compression in compression and in extension ``k_ss μ / (tan α_w ∓ μ)`` [N/m], and
    ``C_slope`` [N s/m] (`wedge_table`); per contact the track damping [N s/m] and its
    number of axles (`contact_table`).
    """
    m = run_matrices([model], [dt])
    return StepMatrices._make(a if f.endswith("_idx") else a[0] for f, a in m._asdict().items())


def highest_frequency(M, K) -> float:
    """Highest undamped natural angular frequency of ``(K, M)`` [rad/s]."""
    m = np.diag(M)
    scaled = K / np.sqrt(np.outer(m, m))
    return float(np.sqrt(max(np.linalg.eigvalsh(scaled).max(), 0.0)))


STEPS_PER_PERIOD = 50
"""Default Δt gives this many steps per period of the highest natural frequency: the
central-difference period error is about (ωΔt)²/24 = 0.07 %."""
