"""One assembly for every model: bodies, points on them, and elements between points.

A point's vertical displacement (positive down) is ``bounce + lateral * roll -
longitudinal * pitch`` for the degrees of freedom its body has; lateral is positive to
the left, longitudinal positive to the front (seed 5.30: the body over the front-left
suspension moves ``y1 + b θ - b_cc α``). An element between points P (on body A) and Q
(on body B) sees ``d = u_P - u_Q``, positive when it compresses, and puts
``D^T f`` into the equations of motion ``M q'' + C q' + K q + Dw^T F + Dc^T f = 0``.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.4, eqs 5.19-5.33 (the 11-DOF model the
assembled matrices reproduce term by term).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MOTIONS = ("bounce", "roll", "pitch")


@dataclass(frozen=True)
class Body:
    """A rigid body with some of the motions bounce [m], roll [rad] and pitch [rad].

    Parameters
    ----------
    name : str
        Body name, e.g. ``"body"``, ``"front_bogie"``.
    mass : float
        Mass [kg].
    roll_inertia : float
        Roll inertia [kg m^2]; needed when the body rolls.
    pitch_inertia : float
        Pitch inertia [kg m^2]; needed when the body pitches.
    motions : tuple of str
        Degrees of freedom, from ``MOTIONS``.
    """

    name: str
    mass: float
    roll_inertia: float = 0.0
    pitch_inertia: float = 0.0
    motions: tuple[str, ...] = ("bounce",)

    def at(self, lateral: float = 0.0, longitudinal: float = 0.0) -> Point:
        """The point ``lateral`` [m] to the left and ``longitudinal`` [m] ahead of the centre."""
        return Point(self, lateral, longitudinal)


@dataclass(frozen=True)
class Point:
    """A point on a body; ``ground`` when ``body`` is None."""

    body: Body | None
    lateral: float = 0.0
    longitudinal: float = 0.0


@dataclass(frozen=True)
class Spring:
    """Linear spring of stiffness ``k`` [N/m] between points ``p`` and ``q``.

    ``suspension`` names a secondary suspension (e.g. ``"FL"``) whose displacement is
    reported; empty for other springs.
    """

    p: Point
    q: Point
    k: float
    suspension: str = ""


@dataclass(frozen=True)
class Damper:
    """Linear viscous damper ``c`` [N s/m] between ``p`` and ``q`` (``q`` may be ground)."""

    p: Point
    q: Point
    c: float


@dataclass(frozen=True)
class Wedge:
    """Friction wedge between ``p`` (sprung side) and ``q`` (eqs 5.30-5.33).

    Parameters
    ----------
    name : str
        Label, e.g. ``"FL"``.
    k_ss : float
        Wedge spring stiffness [N/m].
    x_ss : float
        Static wedge spring compression [m].
    mu : float
        Friction coefficient [-].
    alpha_w : float
        Wedge angle [rad].
    c_slope : float
        Slope of the viscous law near zero relative velocity [N s/m].
    """

    name: str
    p: Point
    q: Point
    k_ss: float
    x_ss: float
    mu: float
    alpha_w: float
    c_slope: float


@dataclass(frozen=True)
class Contact:
    """A wheel-rail contact: the track under one or more axles on one rail.

    With several axles (the bogie approximation of 5.4.3) the contact sees the mean of
    their loaded profiles and the sum of their stiffnesses, and reports the mean wheel load.

    Parameters
    ----------
    name : str
        Label, e.g. ``"FL"``.
    p : Point
        Contact point on the wheelset.
    rail : {"left", "right"}
        Rail under the contact.
    axles : tuple of float
        Axle positions ahead of the vehicle centre [m].
    damping : float
        Track damping ρ2 of the contact [N s/m].
    side : str
        Bogie side the wheel belongs to (e.g. ``"FL"``) when the contact is one of several
        single wheels reported also as their mean; empty otherwise.
    """

    name: str
    p: Point
    rail: str
    axles: tuple[float, ...]
    damping: float
    side: str = ""


@dataclass
class Assembly:
    """Collects bodies and elements and yields the matrices the solver needs."""

    bodies: list[Body] = field(default_factory=list)
    springs: list[Spring] = field(default_factory=list)
    dampers: list[Damper] = field(default_factory=list)
    wedges: list[Wedge] = field(default_factory=list)
    contacts: list[Contact] = field(default_factory=list)

    def add(self, *items):
        """Add bodies and elements; returns the first item for chaining."""
        kinds = {
            Body: self.bodies,
            Spring: self.springs,
            Damper: self.dampers,
            Wedge: self.wedges,
            Contact: self.contacts,
        }
        for item in items:
            kinds[type(item)].append(item)
        return items[0]

    @property
    def dofs(self) -> list[tuple[Body, str]]:
        return [(body, m) for body in self.bodies for m in MOTIONS if m in body.motions]

    def row(self, point: Point) -> np.ndarray:
        """Map from the generalised coordinates to the point's vertical displacement."""
        r = np.zeros(len(self.dofs))
        if point.body is None:
            return r
        factor = {"bounce": 1.0, "roll": point.lateral, "pitch": -point.longitudinal}
        for i, (body, motion) in enumerate(self.dofs):
            if body is point.body:
                r[i] = factor[motion]
        return r

    def relative(self, p: Point, q: Point) -> np.ndarray:
        return self.row(p) - self.row(q)

    def mass_matrix(self) -> np.ndarray:
        inertia = {"bounce": "mass", "roll": "roll_inertia", "pitch": "pitch_inertia"}
        return np.diag([getattr(body, inertia[m]) for body, m in self.dofs])

    def stiffness_matrix(self) -> np.ndarray:
        """Springs only; the track stiffness enters through the contacts [N/m]."""
        n = len(self.dofs)
        k = np.zeros((n, n))
        for s in self.springs:
            d = self.relative(s.p, s.q)
            k += s.k * np.outer(d, d)
        return k

    def damping_matrix(self) -> np.ndarray:
        """Dampers and the track damping of each contact [N s/m]."""
        n = len(self.dofs)
        c = np.zeros((n, n))
        for dmp in self.dampers:
            d = self.relative(dmp.p, dmp.q)
            c += dmp.c * np.outer(d, d)
        for con in self.contacts:
            d = self.row(con.p)
            c += con.damping * np.outer(d, d)
        return c

    def build(self, name: str, static_wheel_load: float, axles_per_rail: int,
              gross_mass: float) -> Model:  # fmt: skip
        """Freeze the assembly into the plain arrays the solver integrates.

        Parameters
        ----------
        name : str
            Model name.
        static_wheel_load : float
            Static load per wheel [N].
        axles_per_rail : int
            Wheels of the whole vehicle on each rail.
        gross_mass : float
            Gross mass of the whole vehicle [kg].
        """
        w = self.wedges
        sec = [s for s in self.springs if s.suspension]
        return Model(
            name=name,
            dof_names=tuple(f"{body.name}_{m}" for body, m in self.dofs),
            M=self.mass_matrix(),
            K=self.stiffness_matrix(),
            C=self.damping_matrix(),
            suspension_names=tuple(s.suspension for s in sec),
            Ds=np.array([self.relative(s.p, s.q) for s in sec]).reshape(len(sec), len(self.dofs)),
            wedge_names=tuple(x.name for x in w),
            Dw=np.array([self.relative(x.p, x.q) for x in w]).reshape(len(w), len(self.dofs)),
            wedge_params=np.array(
                [[x.k_ss, x.x_ss, x.mu, np.tan(x.alpha_w), x.c_slope] for x in w]
            ).reshape(len(w), 5),
            contact_names=tuple(c.name for c in self.contacts),
            Dc=np.array([self.row(c.p) for c in self.contacts]),
            contact_rails=tuple(c.rail for c in self.contacts),
            contact_axles=tuple(c.axles for c in self.contacts),
            contact_damping=np.array([c.damping for c in self.contacts]),
            contact_sides=tuple(c.side for c in self.contacts),
            static_wheel_load=static_wheel_load,
            axles_per_rail=axles_per_rail,
            gross_mass=gross_mass,
        )


@dataclass(frozen=True)
class Model:
    """A vehicle/track model as plain arrays (SI units).

    ``M q'' + C q' + K q + Dw^T F(Dw q, Dw q') + Dc^T f(Dc q, t) = 0``, with ``F`` the wedge
    friction forces and ``f`` the contact forces beyond the static wheel load.

    Attributes
    ----------
    dof_names : tuple of str
        Generalised coordinates, ``<body>_<motion>``.
    M, K, C : ndarray
        Mass [kg, kg m^2], spring stiffness [N/m] and damping [N s/m] matrices.
    suspension_names : tuple of str
    Ds : ndarray
        Rows mapping q to the displacement across each secondary suspension.
    wedge_names : tuple of str
    Dw : ndarray
        Rows mapping q to the displacement across each wedge's suspension.
    wedge_params : ndarray
        Per wedge ``k_ss [N/m], x_ss [m], mu [-], tan(alpha_w) [-], C_slope [N s/m]``.
    contact_names : tuple of str
    Dc : ndarray
        Rows mapping q to each contact's displacement.
    contact_rails : tuple of str
    contact_axles : tuple of tuple of float
        Axle positions of each contact ahead of the vehicle centre [m].
    contact_damping : ndarray
        Track damping per contact [N s/m].
    contact_sides : tuple of str
        Bogie side of each single-wheel contact (``""`` if not grouped).
    static_wheel_load : float
        Static load per wheel [N].
    axles_per_rail : int
        Wheels of the whole vehicle on each rail (a bogie wagon: 4, a two-axle wagon: 2);
        a model with fewer wheels on a rail stands for them in proportion.
    gross_mass : float
        Gross mass of the whole vehicle [kg].
    """

    name: str
    dof_names: tuple[str, ...]
    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    suspension_names: tuple[str, ...]
    Ds: np.ndarray
    wedge_names: tuple[str, ...]
    Dw: np.ndarray
    wedge_params: np.ndarray
    contact_names: tuple[str, ...]
    Dc: np.ndarray
    contact_rails: tuple[str, ...]
    contact_axles: tuple[tuple[float, ...], ...]
    contact_damping: np.ndarray
    contact_sides: tuple[str, ...]
    static_wheel_load: float
    axles_per_rail: int
    gross_mass: float

    @property
    def reach(self) -> tuple[float, float]:
        """Rearmost and foremost axle position relative to the vehicle centre [m]."""
        axles = [x for group in self.contact_axles for x in group]
        return min(axles), max(axles)
