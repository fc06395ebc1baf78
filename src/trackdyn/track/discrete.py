"""A discretely supported track: rails on pads, sleepers, and ballast behind seating gaps.

The track model of ``[run] track = "discrete"`` (`trackdyn.solver.discrete` integrates
it with the vehicle). Per rail:

- the rail, an Euler-Bernoulli beam of Hermite cubic elements, one element per sleeper
  bay, nodes at the sleepers (deflection and rotation), with its mass ``ρA`` lumped at the
  nodes over the tributary length and no rotary inertia (the solver condenses the
  rotations out). Euler-Bernoulli is enough below about 500 Hz: shear deformation and
  rotary inertia (Timoshenko) matter once the bending wavelength nears a few rail heights,
  above about 500 Hz for a 60E1 rail (its pinned-pinned resonance lies near 1 kHz; Knothe
  & Grassie 1993);
- a rail pad at every sleeper, spring ``kp`` and damper ``cp``, between the rail node and
  the sleeper;
- a sleeper mass ``Ms`` per rail seat (half a sleeper per rail: the two rails are
  independent and meet only through the vehicle);
- under each sleeper the ballast and subgrade, tensionless: a linear spring ``kb`` and
  damper ``cb`` behind the sleeper's seating gap, bearing only while the sleeper has
  closed it (the gap opens and closes), plus gravity on rail and sleepers.

The stiffness split. The supports file gives each sleeper's load-deflection curve under a
wheel; its linearisation ``k2`` (5.9-5.11) becomes a rail-seat stiffness ``kd`` (eq 5.7
times the sleeper spacing, `LinearisedTrack.support_stiffness`, as the deterioration loop's
rail beam uses) and the curve's intercept a seating gap (`LinearisedTrack.seating_gap`).
Pad and ballast act in series (Esveld 2001, §4.3; Dahlberg 2010), ``1/kd = 1/kp + 1/kb``:
the pad keeps its published stiffness and the ballast and subgrade take the rest of the
measured flexibility, ``kb = kd kp / (kp - kd)``. The gap is defined as in the rail beam of
`trackdyn.beam.railseat`: the rail deflection at which the rail seat starts to bear, with
the self-weight of rail and sleeper; at rest the two models agree exactly. A sleeper's gap
is its seating gap in excess of the median of its neighbours (±`VOID_NEIGHBOURS`), the
rule of the deterioration loop's ballast (`trackdyn.deterioration.ballast`): a void under
that sleeper alone; the common part is the curvature of the measured curves, seating of
the whole track, which moves the rail as a whole and is left out.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.1-5.2 (eq 5.7,
the linearisation).

Esveld, C. (2001). Modern Railway Track, 2nd ed. MRT-Productions, Zaltbommel, §4.3
(track stiffness of components in series).

Dahlberg, T. (2010). Railway track stiffness variations - consequences and
countermeasures. International Journal of Civil Engineering 8(1), 1-12.

Knothe, K.L., Grassie, S.L. (1993). Modelling of railway track and vehicle/track
interaction at high frequencies. Vehicle System Dynamics 22(3-4), 209-262.

Zhai, W.M., Wang, K.Y., Lin, J.H. (2004). Modelling and experiment of railway ballast
vibrations. Journal of Sound and Vibration 270, 673-683 (half-sleeper mass, ballast
damping).

Zhai, W.M., Wang, K.Y., Cai, C.B. (2009). Fundamentals of vehicle-track coupled
dynamics. Vehicle System Dynamics 47(11), 1349-1376 (the Hertz constant of a wheel).

Castillo-Mingorance, J.M., Sol-Sánchez, M., Mattinzioli, T., Moreno-Navarro, F.,
Rubio-Gámez, M.C. (2022). Development of rail pads from recycled polymers for ballasted
railway tracks. Construction and Building Materials 337, 127479 (high-density
polyethylene pads: static stiffness about 800 kN/mm).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import solve_banded
from scipy.ndimage import median_filter

from trackdyn.beam.railseat import RailBeam, rest_state
from trackdyn.beam.static import linear_supports, solve_beam
from trackdyn.errors import TrackdynInputError
from trackdyn.track.rails import DEFAULT_RAIL, rail_section
from trackdyn.track.track import RAILS, Geometry, LinearisedTrack
from trackdyn.track.winkler import stiffness_from_modulus
from trackdyn.units import GRAVITY

VOID_NEIGHBOURS = 5
"""Sleepers each side whose median seating gap counts as seating of the whole track."""


def void_gap(seating_gap: np.ndarray) -> np.ndarray:
    """Seating gap in excess of the median of the neighbours, per rail and sleeper [m]."""
    size = (1, 2 * VOID_NEIGHBOURS + 1)
    return np.maximum(seating_gap - median_filter(seating_gap, size=size, mode="nearest"), 0.0)


@dataclass(frozen=True)
class DiscreteParameters:
    """Parameters of the discrete track that the supports file does not give (SI units).

    Parameters
    ----------
    rail : str
        Rail section (`trackdyn.track.rails`): EI, ``ρA``; ``ρI`` from its density.
    pad_stiffness : float
        Rail pad stiffness ``kp`` [N/m]; 800 MN/m, the static stiffness of high-density
        polyethylene pads (Castillo-Mingorance et al. 2022), the stiff pads of heavy-haul
        concrete-sleeper track; softer pads cannot carry the stiffest rail seats of the
        built-in example (260 MN/m on its structure).
    pad_damping : float
        Rail pad damping ``cp`` [N s/m]; 50 kN s/m, illustrative.
    sleeper_mass : float
        Sleeper mass per rail seat ``Ms`` [kg]; 125.5 kg, the half sleeper of Zhai et al.
        (2004), as the deterioration loop's default.
    ballast_damping : float
        Ballast damping per rail seat ``cb`` [N s/m]; 58.8 kN s/m, Zhai et al. (2004).
    wheel_radius : float
        Wheel radius for the Hertz constant [m]; 0.4575 m, illustrative (a 915 mm wheel).
    margin : float
        Track each side of the outermost axles that moves with the vehicle [m]; 6 m: the
        rail's response to a wheel load decays as ``e^(-x/L_c)``, below 0.1 % at 6 m for a
        characteristic length of 0.8 m (as the rail-seat windows, `trackdyn.beam.railseat`).
    """

    rail: str = DEFAULT_RAIL
    pad_stiffness: float = 800e6
    pad_damping: float = 50e3
    sleeper_mass: float = 125.5
    ballast_damping: float = 58.8e3
    wheel_radius: float = 0.4575
    margin: float = 6.0


def hertz_stiffness(wheel_load: float, wheel_radius: float) -> float:
    """Linearised Hertz contact stiffness at a static wheel load [N/m].

    ``P = (δ / G)^(3/2)`` with ``G = 4.57e-8 R^-0.149`` m/N^(2/3) for a worn wheel tread
    (Zhai et al. 2009); the tangent ``dP/dδ = 3/2 P^(1/3) / G``.

    Parameters
    ----------
    wheel_load : float
        Static wheel load [N].
    wheel_radius : float
        Wheel radius [m].
    """
    G = 4.57e-8 * wheel_radius**-0.149
    return 1.5 * wheel_load ** (1.0 / 3.0) / G


@dataclass(frozen=True)
class DiscreteTrack:
    """Both rails of a section on discrete supports, extended at each end.

    Arrays per node run over the sleepers of the section extended by copies of its end
    sleepers (at the end spacing) as far as the window reaches beyond the section; rail
    arrays have shape (2 rails, nodes).

    Parameters
    ----------
    lin : LinearisedTrack
        The track it was made from (its geometry: the unloaded rails at rest [m]).
    position : ndarray
        Node (sleeper) positions [m].
    first, count : int
        Index of the section's first sleeper in the node arrays, and its number of sleepers.
    kd, kb : ndarray
        Rail-seat stiffness (pad and ballast in series) and ballast stiffness [N/m].
    gap : ndarray
        Rail deflection at which each rail seat starts to bear (self-weight included) [m].
    params : DiscreteParameters
        Pad, sleeper, ballast and wheel parameters.
    EI, rail_mass, rail_rotary : float
        Rail bending stiffness [N m^2], mass [kg/m] and rotary inertia ``ρI`` [kg m] (the
        rail's; the solver leaves it out, `trackdyn.solver.discrete`).
    rest : ndarray
        Rail deflection, rail rotation and sleeper displacement at rest under self-weight,
        shape (3, 2, nodes) [m, rad, m].
    """

    lin: LinearisedTrack
    position: np.ndarray
    first: int
    count: int
    kd: np.ndarray
    kb: np.ndarray
    gap: np.ndarray
    params: DiscreteParameters
    EI: float
    rail_mass: float
    rail_rotary: float
    rest: np.ndarray

    @property
    def geometry(self) -> Geometry:
        """Unloaded space curve of the rails at rest [m]."""
        return self.lin.track.geometry

    @property
    def sleeper_gap(self) -> np.ndarray:
        """Gap between sleeper and ballast at zero sleeper displacement, (2, nodes) [m]."""
        return self.gap + self.params.sleeper_mass * GRAVITY / self.params.pad_stiffness

    @property
    def spacing(self) -> np.ndarray:
        """Tributary length of each node [m]."""
        return np.gradient(self.position)

    def point_stiffness(self) -> np.ndarray:
        """Track stiffness under a wheel at each node, eq 5.8 from ``kd / spacing``, (2, nodes)
        [N/m]."""
        return stiffness_from_modulus(self.kd / self.spacing, self.EI)

    def ballast_force(self, state: np.ndarray) -> np.ndarray:
        """Static sleeper-ballast contact force of a state ``(w, θ, zs)``, (2, nodes) [N]."""
        pen = state[2] - self.sleeper_gap
        return np.where(pen > 0, self.kb * pen, 0.0)

    def static(self, axle_x, axle_rail, load, nodes=None):
        """Static state with wheel loads on the rails, self-weight included.

        Solved over the nodes ``nodes`` (a slice; default all), free at its ends; the rest
        state elsewhere. In one load step of `solve_beam`: its energy, of linear tensionless
        springs, is convex, so Newton with its line search converges from the unloaded rail
        (the start of the example's 1 km run: the same state as in ten steps to 2e-18 m, in
        a third of the time).

        Parameters
        ----------
        axle_x : ndarray
            Axle positions [m].
        axle_rail : ndarray of int
            Rail of each axle (0 left, 1 right).
        load : ndarray
            Wheel load of each axle, >= 0 [N] (0: the wheel is lifted).

        Returns
        -------
        state : ndarray
            Rail deflection, rail rotation and sleeper displacement, (3, 2, nodes).
        rail : ndarray
            Rail deflection under each axle [m].
        """
        part = slice(None) if nodes is None else nodes
        x = self.position[part]
        p = self.params
        weight = (self.rail_mass * self.spacing[part] + p.sleeper_mass) * GRAVITY
        state = self.rest.copy()
        rail = np.zeros(len(axle_x))
        for r in range(len(RAILS)):
            mine = np.flatnonzero((np.asarray(axle_rail) == r) & (np.asarray(load) > 0))
            gap = self.gap[r, part]
            shift = max(0.0, -float(gap.min()))  # a uniform shift keeps gaps >= 0
            supports = linear_supports(x, self.kd[r, part], gap + shift)
            wheels = np.asarray(axle_x)[mine], np.asarray(load)[mine]
            sol = solve_beam(
                supports, self.EI, np.r_[x, wheels[0]], np.r_[weight, wheels[1]],
                max_element=4 * np.max(np.diff(x)), load_steps=1,
            )  # fmt: skip
            nodes = np.searchsorted(sol.x, x)
            pad = sol.support_force - p.sleeper_mass * GRAVITY
            w = sol.deflection[nodes] - shift
            state[:, r, part] = w, sol.rotation[nodes], w - pad / p.pad_stiffness
            if mine.size:  # the weights, at the nodes, bend no element between them
                under = replace(sol, load_position=wheels[0], load=wheels[1])
                rail[mine] = under.deflection_at(wheels[0]) - shift
        return state, rail


MAX_GAP_SPACINGS = 3.0
"""Widest gap between neighbouring sleepers of the discrete track [median sleeper
spacings]: two sleepers missing in a row. Over a wider gap the rail hangs from its
neighbours and the sleepers at its ends settle fast: the deterioration of a 300 m section
with a 2.4 m gap among 0.6 m spacings settled 14 mm in 0.1 MGT and did not reach its
horizon (50 MGT) in 120 s."""


def _check_gaps(position: np.ndarray, where: str) -> None:
    """Refuse sleepers more than `MAX_GAP_SPACINGS` median spacings apart."""
    gap = np.diff(position)
    spacing = float(np.median(gap))
    wide = np.flatnonzero(gap > MAX_GAP_SPACINGS * spacing)
    if wide.size:
        i = wide[0]
        raise TrackdynInputError(
            f"{where}: sleepers at {position[i]:g} and {position[i + 1]:g} m are "
            f"{gap[i]:.3g} m apart, more than the discrete track's plausible "
            f"{MAX_GAP_SPACINGS:g} spacings of {spacing:.3g} m (two sleepers missing)"
        )


def discrete_track(lin: LinearisedTrack, params: DiscreteParameters | None = None, *,
                   stiffness=None, gap=None) -> DiscreteTrack:  # fmt: skip
    """The discrete track of a linearised track (or of a rail beam's stiffness and gaps).

    Parameters
    ----------
    lin : LinearisedTrack
        The track linearised about the vehicle's static wheel load: geometry, ``k2`` and
        seating gap per sleeper.
    params : DiscreteParameters, optional
        Pad, sleeper, ballast and wheel parameters; default `DiscreteParameters()`.
    stiffness : ndarray, optional
        Rail-seat stiffness per rail and sleeper [N/m], (2, sleepers); default from ``k2``
        (eq 5.7 times the spacing).
    gap : ndarray, optional
        Rail-seat gap per rail and sleeper [m], (2, sleepers), as in
        `trackdyn.beam.railseat`; default the void of the linearisation (`void_gap`).
    """
    p = params or DiscreteParameters()
    section = rail_section(p.rail)
    pos = lin.track.supports.position
    _check_gaps(pos, lin.track.supports.where)
    kd = lin.support_stiffness(section.EI) if stiffness is None else np.asarray(stiffness)
    gap = void_gap(lin.seating_gap()) if gap is None else np.asarray(gap)
    soft = kd >= 0.9 * p.pad_stiffness
    if soft.any():
        r, i = np.unravel_index(int(np.argmax(soft)), soft.shape)
        raise TrackdynInputError(
            f"{lin.track.supports.where}: {RAILS[r]} rail, sleeper at {pos[i]:g} m: rail-seat "
            f"stiffness {kd[r, i] / 1e6:.0f} kN/mm is not below the rail pad's "
            f"{p.pad_stiffness / 1e6:.0f} kN/mm (pad and ballast act in series); the discrete "
            "track cannot carry it"
        )
    ends = np.diff(pos[[0, 1, -2, -1]])[[0, 2]]
    extra = [int(np.ceil(p.margin / e)) + 2 for e in ends]
    x = np.r_[pos[0] - ends[0] * np.arange(extra[0], 0, -1), pos,
              pos[-1] + ends[1] * np.arange(1, extra[1] + 1)]  # fmt: skip

    def padded(v):
        return np.pad(np.asarray(v, dtype=float), ((0, 0), tuple(extra)), mode="edge")

    kd, gap = padded(kd), padded(gap)
    density = section.mass / section.area
    track = DiscreteTrack(
        lin, x, extra[0], pos.size, kd, kd * p.pad_stiffness / (p.pad_stiffness - kd),
        gap, p, section.EI, section.mass, density * section.second_moment,
        np.zeros((3, len(RAILS), x.size)),
    )  # fmt: skip
    return DiscreteTrack(**{**track.__dict__, "rest": _rest(track)})


def _rest(track: DiscreteTrack) -> np.ndarray:
    """Rail deflection, rotation and sleeper displacement at rest, (3, 2, nodes).

    The rail seats bear as the rail beam's tensionless springs of `trackdyn.beam.railseat`
    (its active-set solve, self-weight of rail and sleeper lumped at the rail seat); the
    rotations follow from the deflections (no moments act at the nodes).
    """
    x, p = track.position, track.params
    weight = (track.rail_mass * track.spacing + p.sleeper_mass) * GRAVITY
    L = np.diff(x)
    b, c4, c2 = 6 * track.EI / L**2, 4 * track.EI / L, 2 * track.EI / L
    tri = np.zeros((3, x.size))  # the rotations' stiffness, tridiagonal
    tri[0, 1:], tri[2, :-1] = c2, c2
    tri[1, :-1] += c4
    tri[1, 1:] += c4
    state = np.empty((3, len(RAILS), x.size))
    for r in range(len(RAILS)):
        rest = rest_state(RailBeam(x, track.kd[r], weight, track.EI), track.gap[r])
        dw = b * np.diff(rest.deflection)  # b (w_{i+1} - w_i) per element
        moment = np.zeros(x.size)  # -(K_θw w) at each node
        moment[:-1] += dw
        moment[1:] += dw
        theta = solve_banded((1, 1), tri, moment)
        pad = rest.force - p.sleeper_mass * GRAVITY
        state[:, r] = rest.deflection, theta, rest.deflection - pad / p.pad_stiffness
    return state
