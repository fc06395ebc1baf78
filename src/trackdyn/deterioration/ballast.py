"""Ballast level under each rail seat, the gaps it opens, and what the rail does about it.

Settlement lowers the ballast under a rail seat; the sleeper stays on the rail until the
rail comes down onto the ballast, so a sleeper whose ballast sinks faster than its
neighbours' hangs. The rail of each side is a `trackdyn.beam.railseat.RailBeam`:
one linear, tensionless spring per sleeper with the stiffness equivalent to the measured
``k2`` (eq 5.7 times the spacing, `LinearisedTrack.support_stiffness`) behind a gap. The
gap at the start is the sleeper's seating gap in excess of the median of its neighbours
(`trackdyn.track.discrete.void_gap`): a void under that sleeper alone; the common part is
seating of the whole track and stays in the measured linearisation. A freshly tamped
start (``seated``) closes these voids. Settlement ``b`` [m] adds to the gap.

From the beam, each step re-derives (all changes from the start state, so that the
first step runs on the track as it starts):

- the unloaded profile: measured profile plus the change of the rail's self-weight
  deflection, interpolated linearly between sleepers;
- the linearisation of eqs 5.9-5.11 at each sleeper: ``k2`` scaled by the beam's secant
  stiffness under ``Ps (1 ± δ)`` over its value at the start, ``ys`` plus the change of
  the beam's mean deflection under those loads.

The rate field: a lognormal factor per sleeper on every settlement increment, ``exp(σ z -
σ²/2)`` with ``σ² = ln(1 + cov²)`` and ``z`` a unit Gaussian field with correlation length
``ℓ`` (`trackdyn.track.synthetic.correlated_field`), the two rails' fields correlated by
`RAIL_CORRELATION`; or a field given per rail seat (`read_rate_field`: a file of
`trackdyn calibrate`, ``rate_field.csv``), used as it is.

References
----------
Shenton, M.J. (1985). Ballast deformation and track deterioration. In: Track
Technology, Thomas Telford, London, 253-265.

Sato, Y. (1995). Japanese studies on deterioration of ballasted track. Vehicle System
Dynamics 24 (suppl.), 197-208.

Nielsen, J.C.O., Li, X. (2018). Railway track geometry degradation due to differential
settlement of ballast/subgrade - Numerical prediction by an iterative procedure. Journal
of Sound and Vibration 412, 441-456.

Zhai, W.M., Wang, K.Y., Lin, J.H. (2004). Modelling and experiment of railway ballast
vibrations. Journal of Sound and Vibration 270, 673-683.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from trackdyn.beam.railseat import RailBeam, RailRest, WindowLoads, Windows, rest_state
from trackdyn.errors import TrackdynInputError, shown
from trackdyn.io import read_table
from trackdyn.track.discrete import void_gap
from trackdyn.track.synthetic import correlated_field
from trackdyn.track.track import RAILS, Geometry, LinearisedTrack
from trackdyn.units import GRAVITY

MAX_FACTOR = 100.0
"""Largest settlement-rate factor a rate-field file may give [-]: a typing error beyond."""

MAX_RATE_COV = 3.0
"""Largest settlement-rate coefficient of variation accepted [-]: a typing error beyond
(a percentage typed for a fraction), not a judgement on ballast."""

MAX_RATE_CORRELATION_M = 1000.0
"""Longest correlation length of the settlement-rate field accepted [m]: beyond, the field
is uniform over any section and its smoothing kernel (8 correlation lengths of sleepers)
outgrows the memory."""

RAIL_CORRELATION = 0.7
"""Correlation of the left and right rails' rate fields [-]; illustrative, the value
`trackdyn.track.synthetic.synthetic_track` uses for its stiffness fields."""


RATE_FIELD_COLUMNS = ("distance_m", "rail", "factor")
"""Columns a rate-field file needs (`read_rate_field`); others (``standard_error``) are
ignored."""

PACKED_GAP = 1e-6
"""Largest gap a tamped sleeper may keep under it [m] (`Ballast.tamp`)."""

PACKING_PASSES = 8
"""Passes of packing at most (`Ballast.tamp`): each packs the sleepers still hanging."""

MATCH_TOLERANCE = 0.25
"""Largest distance between a rail seat and its row of a rate-field file, as a fraction of
the sleeper spacing [-]."""


def check_rate_field(cov: float, correlation_length: float) -> None:
    """Refuse a rate field's ``cov`` [-] or ``correlation_length`` [m] outside its
    plausible range (`MAX_RATE_COV`, `MAX_RATE_CORRELATION_M`)."""
    if not 0 <= cov <= MAX_RATE_COV:
        raise TrackdynInputError(
            f"rate_cov is {shown(cov)}, outside the plausible 0 to {MAX_RATE_COV:g} (a "
            "coefficient of variation, not a percentage)"
        )
    if not 0 < correlation_length <= MAX_RATE_CORRELATION_M:
        raise TrackdynInputError(
            f"rate_correlation_length_m is {shown(correlation_length)} m, outside the "
            f"plausible 0 to {MAX_RATE_CORRELATION_M:g} m"
        )


def rate_field(n: int, spacing: float, cov: float, correlation_length: float, seed,
               given=None):  # fmt: skip
    """Settlement-rate factor per rail and sleeper, shape (2, n) [-]: ``given`` when there
    is one, else lognormal with mean 1.

    Parameters
    ----------
    n : int
        Sleepers.
    spacing : float
        Sleeper spacing [m].
    cov : float
        Coefficient of variation of the factor, >= 0 [-].
    correlation_length : float
        Correlation length of the underlying Gaussian field, > 0 [m].
    seed : int or tuple of int
        Seed of the field.
    given : array_like, optional
        A field given per rail and sleeper, (2, n) [-] (`read_rate_field`); ``cov``,
        ``correlation_length`` and ``seed`` are then not used.
    """
    if given is not None:
        factor = np.asarray(given, dtype=float)
        if factor.shape != (len(RAILS), n) or not np.all(np.isfinite(factor) & (factor > 0)):
            raise TrackdynInputError(
                f"the given rate field has shape {factor.shape} (positive factors needed for "
                f"{len(RAILS)} rails x {n} sleepers)"
            )
        return factor
    check_rate_field(cov, correlation_length)
    rng = np.random.default_rng(seed)
    common = correlated_field(n, spacing, correlation_length, rng)
    c = RAIL_CORRELATION
    z = [c * common + np.sqrt(1 - c * c) * correlated_field(n, spacing, correlation_length, rng)
         for _ in RAILS]  # fmt: skip
    sigma = np.sqrt(np.log1p(cov**2))
    return np.exp(sigma * np.array(z) - sigma**2 / 2)


def read_rate_field(path, position) -> np.ndarray:
    """The settlement-rate factor of each rail seat from a file, (2, n) [-].

    The file (CSV, ``distance_m,rail,factor[,standard_error]``, one row per rail and
    sleeper, as `trackdyn calibrate` writes it) must have a row for every sleeper of each
    rail within `MATCH_TOLERANCE` of the sleeper spacing; rows beyond the track are
    ignored.

    Parameters
    ----------
    path : path
        The CSV file.
    position : ndarray
        Sleeper positions of the track [m].
    """
    frame = read_table(path, RATE_FIELD_COLUMNS, ("standard_error",))
    return _rate_field_of(frame, position, path)


def read_field_draws(path, position) -> np.ndarray:
    """Rate fields drawn from a calibration's posterior, (draws, 2, n) [-].

    The file (CSV, ``distance_m,rail,draw,factor``, one row per draw, rail and sleeper, as
    `trackdyn calibrate` writes ``rate_field_draws.csv``) holds for each draw what
    `read_rate_field` reads; draws in the order of their first row.

    Parameters
    ----------
    path : path
        The CSV file.
    position : ndarray
        Sleeper positions of the track [m].
    """
    frame = read_table(path, (*RATE_FIELD_COLUMNS, "draw"))
    draws = frame.draw.str.strip()
    return np.array([_rate_field_of(frame[draws == d], position, f"{path} (draw {d})")
                     for d in pd.unique(draws)])  # fmt: skip


def _rate_field_of(frame, position, path) -> np.ndarray:
    """`read_rate_field` of the rows ``frame`` read from ``path``."""
    distance = pd.to_numeric(frame.distance_m, errors="coerce").to_numpy()
    factor = pd.to_numeric(frame.factor, errors="coerce").to_numpy()
    rail = frame.rail.str.strip().str.lower().to_numpy()
    bad = ~(np.isfinite(distance) & np.isfinite(factor) & (factor > 0) & (factor <= MAX_FACTOR))
    bad |= ~np.isin(rail, RAILS)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TrackdynInputError(
            f"{path}: line {frame.index[i] + 2}: needs distance_m a number, rail left or "
            f"right and factor in (0, {MAX_FACTOR:g}]; got {frame.distance_m.iloc[i]!r}, "
            f"{frame.rail.iloc[i]!r}, {frame.factor.iloc[i]!r}"
        )
    position = np.asarray(position, dtype=float)
    tolerance = MATCH_TOLERANCE * float(np.median(np.diff(position)))
    out = np.empty((len(RAILS), position.size))
    for r, name in enumerate(RAILS):
        rows = np.flatnonzero(rail == name)
        rows = rows[np.argsort(distance[rows], kind="stable")]
        x, f = distance[rows], factor[rows]
        if x.size == 0:
            raise TrackdynInputError(f"{path}: no rows for the {name} rail")
        again = np.flatnonzero(np.diff(x) == 0)
        if again.size:
            a, b = sorted(frame.index[rows[again[0] : again[0] + 2]] + 2)
            raise TrackdynInputError(
                f"{path}: lines {a} and {b} both give the {name} rail at {x[again[0]]:g} m"
            )
        after = np.clip(np.searchsorted(x, position), 0, x.size - 1)  # the nearest row:
        before = np.maximum(after - 1, 0)  # the one at or after, or the one before
        j = np.where(np.abs(x[before] - position) <= np.abs(x[after] - position), before, after)
        far = np.abs(x[j] - position) > tolerance
        if far.any():
            k = int(np.flatnonzero(far)[0])
            raise TrackdynInputError(
                f"{path}: no {name}-rail row within {tolerance:.3g} m of the sleeper at "
                f"{position[k]:g} m; the field must cover the track ({position[0]:g}-"
                f"{position[-1]:g} m)"
            )
        out[r] = f[j]
    return out


@dataclasses.dataclass(frozen=True)
class BallastState:
    """Both rails at rest on one set of ballast levels.

    Parameters
    ----------
    rails : tuple of RailRest
        Each rail's rest state (gap, deflection, support force, bearing sleepers).
    """

    rails: tuple[RailRest, ...]

    def _stack(self, name):
        return np.array([getattr(r, name) for r in self.rails])

    @property
    def gap(self) -> np.ndarray:
        """Gap between sleeper and ballast at zero rail deflection, (2, n) [m]."""
        return self._stack("gap")

    @property
    def deflection(self) -> np.ndarray:
        """Rail deflection under self-weight, (2, n) [m]."""
        return self._stack("deflection")

    @property
    def force(self) -> np.ndarray:
        """Support forces under self-weight, (2, n) [N]."""
        return self._stack("force")

    @property
    def hanging_gap(self) -> np.ndarray:
        """Gap under each sleeper with the rail at rest, (2, n) [m] (0: it bears)."""
        return np.maximum(self.gap - self.deflection, 0.0)


class Ballast:
    """Both rails of a section on their sleepers and ballast.

    Parameters
    ----------
    lin : LinearisedTrack
        The measured track linearised about the heaviest static wheel load of the traffic
        (sets the support stiffness and the initial voids).
    rail : RailSection
        Rail section (EI and mass per metre).
    sleeper_mass : float
        Sleeper mass per rail seat [kg].
    half : int
        Sleepers each side of a wheel in the beam windows [-].
    seated : bool
        Start with every sleeper seated on its ballast (freshly tamped): the initial voids
        are closed, in the beam and in the linearisation (``ys`` less the void); the
        support curves keep their stiffness. Otherwise the voids are as measured.
    """

    def __init__(self, lin: LinearisedTrack, rail, sleeper_mass: float, half: int = 10,
                 seated: bool = False):  # fmt: skip
        pos = lin.track.supports.position
        if pos.size < 2:
            raise TrackdynInputError("the ballast model needs at least two sleepers")
        spacing = np.gradient(pos)
        weight = (rail.mass * spacing + sleeper_mass) * GRAVITY
        kd = lin.support_stiffness(rail.EI)
        self.position, self.delta, self.weight = pos, lin.delta, weight
        self.beams = [RailBeam(pos, kd[r], weight, rail.EI, half) for r in range(len(RAILS))]
        self.windows = [Windows(b) for b in self.beams]
        void = void_gap(lin.seating_gap())
        self.reseat = void if seated else np.zeros_like(void)  # closed by tamping [m]
        self.void = void - self.reseat
        self.initial = self.state(np.zeros_like(self.void))
        self._secant0: dict[float, tuple[np.ndarray, np.ndarray]] = {}  # by static load
        self._secant_loads: dict[float, list[WindowLoads]] = {}  # placed, by static load

    @property
    def stiffness(self) -> np.ndarray:
        """Support stiffness per rail seat, the spring behind the gap, (2, n) [N/m]."""
        return np.array([b.stiffness for b in self.beams])

    def state(self, level, previous: BallastState | None = None) -> BallastState:
        """Both rails at rest with ballast settlement ``level`` (2, n) [m].

        Parameters
        ----------
        level : ndarray
            Settlement of the ballast under each rail seat, (2, n) [m].
        previous : BallastState, optional
            A state near this one (the previous step's), to start the solve from.
        """
        gap = self.void + level
        start = [None] * len(self.beams) if previous is None else [r.closed for r in previous.rails]
        rails = zip(self.beams, gap, start, strict=True)
        return BallastState(tuple(rest_state(b, g, c) for b, g, c in rails))

    def tamp(self, level, state: BallastState, held, change) -> None:
        """Lift the sleepers ``held`` (2, n) bool with the rail by ``-change`` and pack the
        ballast under them (tamping, `trackdyn.deterioration.maintenance`): no tamped
        sleeper hangs after it.

        Parameters
        ----------
        level : ndarray
            Settlement of the ballast, (2, n) [m].
        state : BallastState
            The rest state before tamping.
        held : ndarray
            Tamped sleepers, (2, n) bool.
        change : ndarray
            Change of the rail's profile at each sleeper, (2, n) [m], positive down.
        """
        seated = state.deflection + change - self.weight / self.stiffness  # bears its weight
        self.void = np.where(held, seated - np.asarray(level), self.void)
        # the rail does not follow a lift that changes from sleeper to sleeper (its
        # bending carries it over the short waves of the tamped profile), so some of
        # the sleepers seated above would hang from it; the machine packs the ballast
        # under every sleeper it holds up to the sleeper at the rail's rest and presses
        # it by the sleeper's own weight, until none hangs
        squeeze = self.weight / self.stiffness
        for _ in range(PACKING_PASSES):
            hanging = np.where(held, self.state(level, state).hanging_gap, 0.0)
            if hanging.max() <= PACKED_GAP:
                break
            self.void = self.void - np.where(hanging > PACKED_GAP, hanging + squeeze, 0.0)

    def geometry(self, measured: Geometry, state: BallastState, sign: float = 1.0) -> Geometry:
        """Unloaded space curve: measured plus the change of the rails' rest deflection
        (``sign = -1``: the measured-equivalent curve that gives ``measured`` at ``state``,
        the reference a tamped track continues from)."""
        g = measured
        change = sign * (state.deflection - self.initial.deflection)
        left, right = (np.interp(g.distance, self.position, c) for c in change)
        return Geometry(g.distance, g.left + left, g.right + right, g.where)

    def wheel_solve(self, r: int, state: BallastState, centre, position, load):
        """Rail-seat forces of rail ``r`` with wheel loads on the rest state.

        Parameters
        ----------
        r : int
            Rail index.
        state : BallastState
            Current rest state.
        centre : ndarray, shape (B,)
            Sleeper under the wheel of each row.
        position, load : ndarray, shape (B, L)
            Wheel positions [m] and loads [N] of each row.

        Returns
        -------
        index, force, deflection : ndarray, shape (B, W)
            Sleeper of each column (``-1`` .. ``n``: beyond the section), total support force
            [N] and rail deflection [m]; see `Windows.solve`.
        """
        return self.force_solve(r, state, self.wheel_forces(r, centre, position, load))

    def wheel_forces(self, r: int, centre, position, load, closed=None) -> WindowLoads:
        """Wheel loads placed on rail ``r``'s windows (`Windows.load_vector`; arguments as
        `wheel_solve`, ``closed`` where the first solve starts). They do not depend on the
        ballast state: the loads of a run are placed once and solved on every state
        (`force_solve`)."""
        return self.windows[r].load_vector(centre, position, load, closed)

    def force_solve(self, r: int, state: BallastState, loads: WindowLoads):
        """`wheel_solve` for wheel loads already placed on the windows (`wheel_forces`)."""
        return self.windows[r].solve(state.rails[r], loads)

    def peak_forces(self, r: int, state: BallastState, loads: WindowLoads, wheels: int):
        """Largest rail-seat force of each sleeper of rail ``r`` over the rows of each of
        ``wheels`` wheels, (wheels, sleepers) [N] (`Windows.peaks`)."""
        return self.windows[r].peaks(state.rails[r], loads, wheels)

    def _secant(self, state: BallastState, static_load: float):
        """Beam secant stiffness [N/m] and mean deflection [m] under ``Ps (1 ± δ)`` (the
        loads placed on the windows once per static load)."""
        n = self.position.size
        centre = np.tile(np.arange(n), 2)
        if static_load not in self._secant_loads:
            load = static_load * np.repeat([1 - self.delta, 1 + self.delta], n)[:, None]
            at = self.position[centre][:, None]
            self._secant_loads[static_load] = [self.wheel_forces(r, centre, at, load)
                                               for r in range(len(RAILS))]  # fmt: skip
        k, ys = [], []
        for r, loads in enumerate(self._secant_loads[static_load]):
            y = self.windows[r].deflection(state.rails[r], loads)
            dy = y[:, self.beams[r].half] - np.tile(state.rails[r].deflection, 2)
            k.append(2 * self.delta * static_load / (dy[n:] - dy[:n]))
            ys.append(0.5 * (dy[n:] + dy[:n]))
        return np.array(k), np.array(ys)

    def linearised(self, lin0: LinearisedTrack, state: BallastState, geometry) -> LinearisedTrack:
        """``lin0`` (the measured linearisation) updated for the current ballast.

        Parameters
        ----------
        lin0 : LinearisedTrack
            Measured track linearised about one static wheel load.
        state : BallastState
            Current rest state.
        geometry : Geometry
            Current unloaded space curve.
        """
        key = lin0.static_load
        if key not in self._secant0:
            self._secant0[key] = self._secant(self.initial, key)
        k0, ys0 = self._secant0[key]
        k, ys = self._secant(state, key)
        track = dataclasses.replace(lin0.track, geometry=geometry)
        ys = lin0.ys - self.reseat + ys - ys0
        return dataclasses.replace(lin0, track=track, k2=lin0.k2 * k / k0, ys=ys)
