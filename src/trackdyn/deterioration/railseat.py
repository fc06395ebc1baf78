"""Rail-seat forces from the rail as a beam on tensionless supports with seating gaps.

The rail of one side is an Euler-Bernoulli beam on one linear, tensionless spring per
sleeper that only bears once the rail has closed that sleeper's gap (a hanging sleeper).
Its dead state (rail and sleeper self-weight, no wheel) is solved once per step over the
whole section with `trackdyn.track.beam.solve_beam`. A wheel load changes it only
locally, so each wheel position is solved on a window of ``2 half + 1`` sleepers centred on
the sleeper under the wheel, for the change from the dead state, held at zero one sleeper
beyond the window (the change at 5 m from a wheel is below 0.1 % for a characteristic
length of 0.8 m, ``e^(-x/L_c)``). The rail rotations of the window are condensed out once
per window, so that each wheel position is a dense system of ``2 half + 1`` unknowns (the
deflections at the sleepers); all positions are solved at once (batched), and the set of
closed supports of each is iterated to convergence (closed where the rail reaches the
ballast, open elsewhere), starting from the dead state's. The section is extended beyond
its ends by copies of its end sleepers, as the track goes on beyond a section.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.track.beam import _hermite, linear_supports, solve_beam

MAX_SWEEPS = 60
"""Active-set iterations allowed per batch of wheel positions."""


@dataclass(frozen=True)
class RailBeam:
    """One rail on its sleepers: what does not change with settlement.

    Parameters
    ----------
    position : ndarray
        Sleeper positions, strictly increasing [m].
    stiffness : ndarray
        Support stiffness per sleeper, the spring behind the gap [N/m].
    weight : ndarray
        Self-weight carried at each sleeper: rail over the sleeper spacing and the
        sleeper's share per rail seat [N].
    EI : float
        Rail bending stiffness [N m^2].
    half : int
        Sleepers each side of the wheel in a window [-].
    """

    position: np.ndarray
    stiffness: np.ndarray
    weight: np.ndarray
    EI: float
    half: int = 8

    def padded(self, values):
        """``values`` per sleeper extended by ``half + 1`` copies of the end values."""
        p = self.half + 1
        return np.pad(np.asarray(values, dtype=float), (p, p), mode="edge")

    @property
    def padded_position(self):
        """Sleeper positions extended with the end spacings [m]."""
        x, p = self.position, self.half + 1
        return np.r_[x[0] - (x[1] - x[0]) * np.arange(p, 0, -1), x,
                     x[-1] + (x[-1] - x[-2]) * np.arange(1, p + 1)]  # fmt: skip


def dead_state(beam: RailBeam, gap):
    """Rail deflection [m] and support forces [N] at each sleeper under self-weight alone.

    Parameters
    ----------
    beam : RailBeam
        The rail and its supports.
    gap : ndarray
        Gap between each sleeper and its ballast at zero rail deflection, >= 0 [m].
    """
    base = float(np.min(gap))  # the whole rail first drops onto the highest ballast
    supports = linear_supports(beam.position, beam.stiffness, np.asarray(gap) - base)
    sol = solve_beam(supports, beam.EI, beam.position, beam.weight, max_element=1e3, max_iter=400)
    return sol.support_deflection + base, sol.support_force


class Windows:
    """Condensed beam stiffness of the window around every sleeper of a `RailBeam`.

    Parameters
    ----------
    beam : RailBeam
        The rail and its supports.
    """

    def __init__(self, beam: RailBeam):
        h, n = beam.half, beam.position.size
        self.beam, self.width = beam, 2 * h + 1
        xp = beam.padded_position
        # window of sleeper i: padded nodes i .. i + 2h + 2; the two outer nodes are held
        nodes = np.arange(n)[:, None] + np.arange(2 * h + 3)[None, :]
        self.x = xp[nodes]  # (n, W + 2) node positions [m]
        length = np.diff(self.x, axis=1)  # (n, W + 1) element lengths
        ndof = 2 * (self.width + 2)
        K = np.zeros((n, ndof, ndof))
        ke = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
        power = np.array([0, 1, 0, 1]) - 1.5
        for e in range(length.shape[1]):
            for a in range(4):
                for b in range(4):
                    K[:, 2 * e + a, 2 * e + b] += (
                        beam.EI * ke[a, b] * length[:, e] ** (power[a] + power[b])
                    )
        inner = np.arange(2, ndof - 2)
        K = K[:, inner][:, :, inner]
        w, t = np.arange(0, 2 * self.width, 2), np.arange(1, 2 * self.width, 2)
        Ktt = K[:, t][:, :, t]
        self.T = np.linalg.solve(Ktt, K[:, t][:, :, w]).transpose(0, 2, 1)  # Kwt Ktt^-1
        self.S = K[:, w][:, :, w] - self.T @ K[:, t][:, :, w]  # condensed stiffness
        self.index = np.arange(n)[:, None] + np.arange(self.width)[None, :]  # into padded

    def load_vector(self, centre, position, load):
        """Condensed nodal forces of point loads, (B, W) [N].

        Parameters
        ----------
        centre : ndarray, shape (B,)
            Window (sleeper index) of each row.
        position, load : ndarray, shape (B, L)
            Load positions [m] and loads [N]; loads outside the window are dropped.
        """
        B, W = centre.size, self.width
        x = self.x[centre]  # (B, W + 2)
        e = np.clip(np.sum(x[:, None, :] <= position[:, :, None], axis=2) - 1, 0, W)
        length = np.take_along_axis(x, e + 1, 1) - np.take_along_axis(x, e, 1)
        s = (position - np.take_along_axis(x, e, 1)) / length
        inside = (s >= 0) & (s <= 1)
        shape = _hermite(np.clip(s, 0, 1), length) * np.where(inside, load, 0.0)  # (4, B, L)
        full = np.zeros((B, 2 * (W + 2)))
        rows = np.repeat(np.arange(B)[:, None], position.shape[1], 1)
        for a in range(4):
            np.add.at(full, (rows, 2 * e + a), shape[a])
        fw, ft = full[:, 2:-2:2], full[:, 3:-2:2]
        return fw - np.einsum("bij,bj->bi", self.T[centre], ft)

    def solve(self, centre, force, gap, deflection, dead_force):
        """Support forces [N] of each row with the loads ``force`` added to the dead state.

        Parameters
        ----------
        centre : ndarray, shape (B,)
            Window (sleeper index) of each row.
        force : ndarray, shape (B, W)
            Condensed nodal forces of the wheel loads (`load_vector`) [N].
        gap, deflection, dead_force : ndarray
            Per sleeper: ballast gap [m], dead-state deflection [m] and support force [N].

        Returns
        -------
        index : ndarray, shape (B, W)
            Sleeper of each column (padded numbering: sleeper ``i`` is ``i + half + 1``).
        support_force : ndarray, shape (B, W)
            Total support force, dead state included [N].
        deflection : ndarray, shape (B, W)
            Total rail deflection [m].
        """
        b = self.beam
        index = self.index[centre] + 1
        k = b.padded(b.stiffness)[index]
        g, u0 = b.padded(gap)[index], b.padded(deflection)[index]
        f0 = b.padded(dead_force)[index]
        closed = u0 > g
        todo = np.arange(centre.size)
        v = np.zeros(force.shape)
        for _ in range(MAX_SWEEPS):
            kc = k[todo] * closed[todo]
            A = self.S[centre[todo]].copy()
            A[:, np.arange(self.width), np.arange(self.width)] += kc
            rhs = force[todo] + f0[todo] - kc * (u0[todo] - g[todo])
            v[todo] = np.linalg.solve(A, rhs[:, :, None])[:, :, 0]
            now = u0[todo] + v[todo] > g[todo]
            changed = np.any(now != closed[todo], axis=1)
            closed[todo] = now
            todo = todo[changed]
            if todo.size == 0:
                break
        else:
            raise TrackdynInputError(
                f"rail-seat forces: the contact of {todo.size} wheel positions did not settle "
                f"in {MAX_SWEEPS} iterations"
            )
        y = u0 + v
        return index, k * np.maximum(y - g, 0.0), y
