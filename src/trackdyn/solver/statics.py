"""What both solvers share: the contact and wedge force laws, the problem, the start.

A `Problem` is one run as the solvers see it: a model, its `TrackInput`, the path of the
vehicle centre ``centre0 + speed t``, the time step and the storage. Both solvers start
from the static equilibrium of the first position, moving with the track (`start_path`),
and store the same arrays (`OUTPUTS`).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, eqs 5.14, 5.30-5.33.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from trackdyn.errors import TrackdynInputError
from trackdyn.track.discrete import DiscreteTrack
from trackdyn.track.inputs import TrackInput
from trackdyn.vehicle.assembly import Model

OUTPUTS = ("q", "v", "a", "wl", "secondary", "fw", "vw", "k", "r")
"""Stored arrays, (stored steps, width): displacement [m], velocity [m/s], acceleration
[m/s²] per dof; wheel load, static and track damping included (mean of the contact's
wheels, `wheel_load`) [N]; displacement across each secondary suspension ``Ds q`` [m];
wedge force [N] and velocity [m/s]; contact stiffness [N/m] and input [m]
(`trackdyn.track.inputs`)."""


@dataclass(frozen=True)
class Problem:
    """One run for a solver.

    Parameters
    ----------
    model : Model
        Vehicle model (`trackdyn.vehicle.assembly.Model`).
    inputs : TrackInput or DiscreteTrack
        Track under the contacts (`trackdyn.track.inputs.TrackInput`), or the discrete
        track itself for `trackdyn.solver.discrete` (`trackdyn.track.discrete.DiscreteTrack`).
    centre0 : float
        Vehicle-centre position at t = 0 [m].
    speed : float
        Vehicle speed [m/s].
    dt : float
        Time step [s]; the central scheme's step, the reference solver's first guess and
        the spacing of the start's static path.
    n_steps : int
        Steps run, t = 0 ... (n_steps - 1) dt.
    store_every : int
        Every n-th step is stored.
    """

    model: Model
    inputs: TrackInput | DiscreteTrack
    centre0: float
    speed: float
    dt: float
    n_steps: int
    store_every: int

    @property
    def n_store(self) -> int:
        """Stored steps."""
        return (self.n_steps - 1) // self.store_every + 1


def track_input(p: Problem) -> TrackInput:
    """``p.inputs`` of a run on the continuous track (the central and reference solvers)."""
    assert not isinstance(p.inputs, DiscreteTrack), "a discrete-track run is solver.discrete's"
    return p.inputs


def widths(model) -> dict[str, int]:
    """Columns of each of the `OUTPUTS` arrays for ``model``."""
    n, nc, nw = len(model.dof_names), len(model.contact_names), len(model.wedge_names)
    ns = len(model.suspension_names)
    return dict(q=n, v=n, a=n, wl=nc, secondary=ns, fw=nw, vw=nw, k=nc, r=nc)


def contact_table(model) -> np.ndarray:
    """Per contact the track damping [N s/m] and the number of axles it stands for."""
    axles = [float(len(a)) for a in model.contact_axles]
    return np.column_stack([model.contact_damping, axles]).reshape(-1, 2)


def wheel_load(model, fc, dv):
    """Wheel load [N], static included: ``static + (fc + c_d dv) / axles`` per contact.

    Parameters
    ----------
    model : Model
        Vehicle model.
    fc : ndarray
        Contact force beyond static without the track damping [N].
    dv : ndarray
        Contact deflection velocity ``Dc v`` [m/s].
    """
    contact = contact_table(model)
    return model.static_wheel_load + (fc + contact[:, 0] * dv) / contact[:, 1]


@njit(cache=True, inline="always")
def contact_table_force(table, y_start, y_step, deflection):
    """Tabulated track force [N] at ``deflection`` [m]: zero before the table, linear after."""
    return table_force_at(table, 0, table.size, y_start, y_step, deflection)


@njit(cache=True, inline="always")
def table_force_at(values, first, size, y_start, y_step, deflection):
    """`contact_table_force` of the table ``values[first:first + size]`` (read in place)."""
    if deflection <= y_start:
        return 0.0
    u = (deflection - y_start) / y_step
    j = int(u)
    last = size - 1
    if j >= last:
        at = first + last
        return values[at] + (u - last) * (values[at] - values[at - 1])
    return values[first + j] + (u - j) * (values[first + j + 1] - values[first + j])


def table_step(grid):
    """First point and spacing of a deflection grid [m] (placeholders when empty)."""
    return (grid[0], grid[1] - grid[0]) if grid.size else (0.0, 1.0)


WEDGE_COLUMNS = 4
"""Columns of a wedge's row of `wedge_table`."""


def wedge_table(model) -> np.ndarray:
    """Per wedge ``x_ss`` [m], the slip force per unit spring compression in compression
    and in extension ``k_ss μ / (tan α_w ∓ μ)`` [N/m], and ``C_slope`` [N s/m]."""
    k_ss, x_ss, mu, tan_a, c_slope = model.wedge_params.T
    wedge = np.column_stack([x_ss, k_ss * mu / (tan_a - mu), k_ss * mu / (tan_a + mu), c_slope])
    return np.ascontiguousarray(wedge.reshape(-1, WEDGE_COLUMNS))


def wedge_forces(wedge, d, v):
    """Friction force of each wedge (eqs 5.30-5.33) [N].

    Parameters
    ----------
    wedge : ndarray
        `wedge_table` of the model.
    d : ndarray
        Displacement across each suspension [m].
    v : ndarray
        Relative velocity across each suspension [m/s].
    """
    normal = np.maximum(wedge[:, 0] + d, 0.0)
    return np.clip(wedge[:, 3] * v, -normal * wedge[:, 2], normal * wedge[:, 1])


def static_state(model, inputs, centre: float) -> np.ndarray:
    """Static equilibrium at one position (wedges at rest carry no friction) [m].

    On linear contacts it is linear; on tabulated contacts (force against deflection from
    the unloaded profile ``r``) Newton starts from the linearised state, where every
    contact is seated.
    """
    x = np.array([centre])
    k, loaded = (a[0] for a in inputs.linear(x))
    Kc = model.K + model.Dc.T @ (k[:, None] * model.Dc)
    q = np.linalg.solve(Kc, model.Dc.T @ (k * loaded))
    grid = inputs.grid
    if grid.size == 0:
        return q
    _, r, table = (a[0] for a in inputs(x))
    y0, dy = table_step(grid)
    for _ in range(100):
        defl = model.Dc @ q - r
        rows = list(zip(defl, table, strict=True))
        force = np.array([contact_table_force(t, y0, dy, d) for d, t in rows])
        seg = np.clip(((defl - y0) // dy).astype(int), 0, grid.size - 2)
        slope = np.array([t[j + 1] - t[j] for j, (_, t) in zip(seg, rows, strict=True)]) / dy
        residual = model.K @ q + model.Dc.T @ (force - model.static_wheel_load)
        jac = model.K + model.Dc.T @ (np.maximum(slope, 1e-6 * k)[:, None] * model.Dc)
        dq = np.linalg.solve(jac, -residual)
        q += dq
        if np.max(np.abs(dq)) < 1e-13:
            return q
    raise TrackdynInputError("no static equilibrium found on the nonlinear track")


def start_path(p: Problem) -> tuple[np.ndarray, np.ndarray]:
    """Displacement [m] and velocity [m/s] at t = 0 on the static path.

    The vehicle starts in the static equilibrium of its first position and moves with the
    track under it: its velocity is the second-order one-sided difference of the static
    states at t = 0, dt and 2 dt.
    """
    q0, q1, q2 = (static_state(p.model, p.inputs, p.centre0 + p.speed * p.dt * i) for i in range(3))
    return q0, (-3 * q0 + 4 * q1 - q2) / (2 * p.dt)


def non_finite(p: Problem, step: int) -> TrackdynInputError:
    """The error of a run whose displacements are not finite from ``step`` on."""
    t = step * p.dt
    return TrackdynInputError(
        f"the run gave non-finite displacements from t = {t:.4f} s (vehicle centre at "
        f"{p.centre0 + p.speed * t:.2f} m): check the time step and the input ranges"
    )


def failure(p: Problem, step: int) -> TrackdynInputError:
    """The error of a run whose wedge friction found no solution at ``step``."""
    t = step * p.dt
    return TrackdynInputError(
        f"Newton iteration of the wedge friction did not converge at t = {t:.4f} s, "
        f"vehicle centre at {p.centre0 + p.speed * t:.2f} m"
    )
