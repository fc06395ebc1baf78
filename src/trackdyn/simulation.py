"""`simulate`: a vehicle model running over a track at constant speed."""

from __future__ import annotations

import numpy as np
import xarray as xr

from trackdyn.errors import TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.progress import progress_bar
from trackdyn.results import make_dataset
from trackdyn.solver.central import (
    STEPS_PER_PERIOD,
    contact_table_force,
    highest_frequency,
    integrate_chunk,
    start_state,
    step_matrices,
)
from trackdyn.track.track import LinearisedTrack, Track, load_surface
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import Vehicle

CHUNK_STEPS = 20_000
"""Steps integrated per compiled call; bounds the memory of the sampled track input."""
OUTPUT_STEP = 1e-3
"""Output interval when ``store_every`` is None [s]: 1 kHz, well above the wheel-load
frequencies of interest (body modes of 1-8 Hz, wheelset on track of 40-60 Hz)."""
TABLE_POINTS = 96
"""Deflection points of the per-step load table of the nonlinear contact."""


class _Inputs:
    """Track input under each contact at given vehicle-centre positions."""

    def __init__(self, model, lin: LinearisedTrack, nonlinear: bool):
        self.model, self.lin, self.nonlinear = model, lin, nonlinear
        if nonlinear:
            if any(len(a) != 1 for a in model.contact_axles):
                raise TrackdynInputError(
                    "the nonlinear track (5.14) is available for single-wheel contacts "
                    "(the 2-DOF model); bogie models use the linearised track"
                )
            top = max(
                c.deflection[-1] for r in ("left", "right") for c in getattr(lin.track.supports, r)
            )
            self.grid = np.linspace(0.0, 1.5 * top, TABLE_POINTS)
            self.surface = {
                r: load_surface(lin.track, r, self.grid) for r in set(model.contact_rails)
            }

    def __call__(self, centre: np.ndarray):
        m = self.model
        k = np.zeros((centre.size, len(m.Dc)))
        r = np.zeros_like(k)
        table = np.zeros((centre.size if self.nonlinear else 0, len(m.Dc), TABLE_POINTS))
        for c, (rail, axles) in enumerate(zip(m.contact_rails, m.contact_axles, strict=True)):
            for offset in axles:
                kk, loaded = self.lin.sample(rail, centre + offset)
                k[:, c] += kk
                r[:, c] += loaded / len(axles)
            if self.nonlinear:
                x = centre + axles[0]
                r[:, c] = self.lin.track.geometry.at(rail, x)
                table[:, c] = self.surface[rail](x)
        return k, r, table


def _static_state(model, k, loaded, r, table, grid):
    """Static equilibrium at the first position (wedges at rest carry no friction).

    On the linearised track it is linear; on the nonlinear track (tabulated contact force
    against deflection from the unloaded profile ``r``) Newton starts from the linearised
    state, where every contact is seated.
    """
    Kc = model.K + model.Dc.T @ (k[:, None] * model.Dc)
    q = np.linalg.solve(Kc, model.Dc.T @ (k * loaded))
    if table.shape[0] == 0:
        return q
    dy = grid[1] - grid[0]
    for _ in range(100):
        defl = model.Dc @ q - r
        rows = list(zip(defl, table[0], strict=True))
        force = np.array([contact_table_force(t, grid[0], dy, d) for d, t in rows])
        seg = np.clip(((defl - grid[0]) // dy).astype(int), 0, grid.size - 2)
        slope = np.array([t[j + 1] - t[j] for j, (_, t) in zip(seg, rows, strict=True)]) / dy
        residual = model.K @ q + model.Dc.T @ (force - model.static_wheel_load)
        jac = model.K + model.Dc.T @ (np.maximum(slope, 1e-6 * k)[:, None] * model.Dc)
        dq = np.linalg.solve(jac, -residual)
        q += dq
        if np.max(np.abs(dq)) < 1e-13:
            return q
    raise TrackdynInputError("no static equilibrium found on the nonlinear track")


def time_step(model, lin: LinearisedTrack, speed: float) -> tuple[float, float, float]:
    """Default time step, stability limit [s] and highest natural frequency [rad/s].

    The frequency is that of the model on the stiffest track along the path; the default
    step gives `STEPS_PER_PERIOD` steps per its period and moves the vehicle no more than
    half a geometry sample interval; the explicit scheme is stable below ``2 / ω_max``.
    """
    k_max = np.array(
        [
            lin.k2[0 if r == "left" else 1].max() * len(a)
            for r, a in zip(model.contact_rails, model.contact_axles, strict=True)
        ]
    )
    omega = highest_frequency(model.M, model.K + model.Dc.T @ (k_max[:, None] * model.Dc))
    spacing = float(np.min(np.diff(lin.track.geometry.distance)))
    dt = min(2 * np.pi / omega / STEPS_PER_PERIOD, 0.5 * spacing / speed)
    return dt, 2.0 / omega, omega


def simulate(
    vehicle: Vehicle,
    track: Track | LinearisedTrack,
    options: RunOptions | None = None,
    *,
    start: float | None = None,
    end: float | None = None,
    progress: bool = False,
    newton_max_iter: int = 50,
) -> xr.Dataset:
    """Run a vehicle model over a track at constant speed.

    The vehicle starts with its rearmost axle at ``start`` in the static equilibrium of
    that position, moving with the track (its velocity is that of the static equilibrium
    carried along the track), and runs until its foremost axle reaches ``end``.

    Parameters
    ----------
    vehicle : Vehicle
        Vehicle parameter set.
    track : Track or LinearisedTrack
        The track; a `Track` is linearised about the vehicle's static wheel load with the
        options' ``delta`` and ``extrapolate``.
    options : RunOptions, optional
        Model, speed, time step, storage, linearisation and track law
        (`trackdyn.options.RunOptions`; default: the 11-DOF model at 60 km/h). The default
        time step gives ``STEPS_PER_PERIOD`` steps per period of the highest natural
        frequency with the stiffest track on the path, and no more than half a geometry
        sample interval of travel per step; a step beyond the stability limit
        ``2 / ω_max`` of the explicit scheme is refused. Without ``store_every`` one step
        is kept about every `OUTPUT_STEP` seconds.
    start, end : float, optional
        Part of the track to run over [m]; default the whole track.
    progress : bool
        Show a progress bar.
    newton_max_iter : int
        Newton iterations allowed per step.

    Returns
    -------
    xarray.Dataset
        See `trackdyn.results.make_dataset`.
    """
    o = RunOptions() if options is None else options
    speed, nonlinear = o.speed, o.nonlinear
    m = build_model(o.model, vehicle)
    lin = (
        track
        if isinstance(track, LinearisedTrack)
        else track.linearise(vehicle.static_wheel_load, o.delta, extrapolate=o.extrapolate)
    )
    lo, hi = lin.track.extent
    rear, front = m.reach
    start = lo if start is None else max(float(start), lo)
    end = hi if end is None else min(float(end), hi)
    c0, c1 = start - rear, end - front
    if c1 <= c0:
        raise TrackdynInputError(
            f"track {start:.1f}-{end:.1f} m is shorter than the vehicle's path: the axles span "
            f"{front - rear:.2f} m"
        )
    default_dt, limit, omega = time_step(m, lin, speed)
    dt = default_dt if o.dt_s is None else o.dt_s
    if dt >= limit:
        raise TrackdynInputError(
            f"time step dt_s = {dt:.3g} s is beyond the stability limit {limit:.3g} s of the "
            f"explicit scheme (highest natural frequency {omega / 2 / np.pi:.1f} Hz)"
        )
    n_steps = int(np.floor((c1 - c0) / (speed * dt))) + 1
    inputs = _Inputs(m, lin, nonlinear)
    mats = step_matrices(m, dt)
    # Start on the static path: the vehicle moves with the track under it from the first
    # step instead of hitting its slope at rest.
    first = c0 + speed * dt * np.arange(3)
    k0, r0, t0 = inputs(first)
    _, loaded0, _ = _Inputs(m, lin, nonlinear=False)(first)
    grid = getattr(inputs, "grid", None)
    q = [_static_state(m, k0[i], loaded0[i], r0[i], t0[i : i + 1], grid) for i in range(3)]
    z = start_state(m, mats[-1], q, dt)
    store_every = o.store_every or max(1, round(OUTPUT_STEP / dt))
    n_store = (n_steps - 1) // store_every + 1
    n, nc, nw = len(m.dof_names), len(m.contact_names), len(m.wedge_names)
    out = {
        name: np.empty((n_store, width))
        for name, width in (
            ("q", n),
            ("v", n),
            ("a", n),
            ("fc", nc),
            ("fw", nw),
            ("vw", nw),
            ("k", nc),
            ("r", nc),
        )
    }
    grid = getattr(inputs, "grid", np.array([0.0, 1.0]))
    stored = 0
    label = f"{m.name} at {o.speed_kmh:.0f} km/h [steps]"
    with progress_bar(progress, n_steps, label) as bar:
        for first in range(0, n_steps, CHUNK_STEPS):
            steps = np.arange(first, min(first + CHUNK_STEPS, n_steps))
            centre = c0 + speed * dt * steps
            k, r, table = inputs(centre)
            keep = steps % store_every == 0
            sl = slice(stored, stored + int(keep.sum()))
            status = integrate_chunk(
                *mats, m.static_wheel_load,
                k, r, table, grid[0], grid[1] - grid[0],
                z, dt, first, store_every, newton_max_iter,
                out["q"][sl], out["v"][sl], out["a"][sl], out["fc"][sl], out["fw"][sl],
                out["vw"][sl],
            )  # fmt: skip
            if status >= 0:
                t = (first + status) * dt
                raise TrackdynInputError(
                    f"Newton iteration of the wedge friction did not converge at t = {t:.4f} s, "
                    f"vehicle centre at {c0 + speed * t:.2f} m"
                )
            out["k"][sl], out["r"][sl] = k[keep], r[keep]
            stored += int(keep.sum())
            bar.advance(len(steps))
    time = np.arange(n_store) * store_every * dt
    return make_dataset(
        m, vehicle, time, c0 + speed * time, out, dt=dt, speed=speed, nonlinear=nonlinear
    )
