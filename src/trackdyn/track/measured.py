"""Measured track stiffness turned into the per-sleeper supports the models run on.

A railway seldom has a load-deflection curve at every sleeper. It has a track stiffness
per rail at one load: continuous from a rolling stiffness measurement vehicle (Banverket's
RSMV, Berggren 2009: the wheel load over the rail's deflection, sampled every metre or
so), or at a few sleepers from falling-weight tests. That is the quantity a support curve
holds (`trackdyn.track.support`: the wheel load on the rail above a sleeper against the
rail's deflection there), at one load only, so two rules are stated here:

- **where**: sleepers `SupportsFormat.sleeper_spacing_m` apart along the geometry, each
  given the measured stiffness interpolated to it, ``linear`` in distance or the
  ``nearest`` measurement's; beyond the first and last measurement the end values hold;
- **how it bends**: ``linear`` (the stiffness at every load), or the ``example`` shape:
  the built-in example's median curve (its sleepers' measured curves, stiffening with load
  as ballast does), its deflections scaled per sleeper so that its secant stiffness at the
  measurement's load is the measured one.

References
----------
Berggren, E. (2009). Railway track stiffness: dynamic measurements and evaluation for
efficient maintenance. PhD thesis, KTH Royal Institute of Technology, Stockholm.
"""

from __future__ import annotations

import functools
from typing import Literal

import numpy as np
from pydantic import Field, PositiveFloat, model_validator

from trackdyn.errors import TrackdynInputError
from trackdyn.limits import MAX_SLEEPER_GAP, SUPPORT_STIFFNESS
from trackdyn.strict import Strict
from trackdyn.track.support import Curves, SupportCurve
from trackdyn.track.track import RAILS, Supports

SLEEPER_SPACING_M = 0.6
"""Sleeper spacing of supports made from a measured stiffness, unless given [m] (concrete
sleepers on main lines; the built-in example's)."""


class SupportsFormat(Strict):
    """What a supports file holds (the ``[track]`` keys shared by every command).

    Parameters
    ----------
    supports_kind : {"curves", "measured"}
        Per-sleeper load-deflection curves or stiffnesses (``distance_m,rail,load_kN,
        deflection_mm`` or ``distance_m,rail,stiffness_kN_per_mm``, a row or a curve per
        sleeper), or a ``measured`` track stiffness per rail at one load at any positions
        (``distance_m,rail,stiffness_kN_per_mm``: a rolling measurement or a few sleepers).
    stiffness_load_kN : float, optional
        The wheel load at which the stiffness was measured [kN]; with ``measured``.
    curve_shape : {"example", "linear"}
        How the supports made of a measured stiffness bend with load (module docstring).
    stiffness_between : {"linear", "nearest"}
        How a measured stiffness is taken to the sleepers between measurements.
    sleeper_spacing_m : float
        Spacing of the sleepers made of a measured stiffness [m].
    """

    supports_kind: Literal["curves", "measured"] = "curves"
    stiffness_load_kN: PositiveFloat | None = None
    curve_shape: Literal["example", "linear"] = "example"
    stiffness_between: Literal["linear", "nearest"] = "linear"
    sleeper_spacing_m: float = Field(SLEEPER_SPACING_M, ge=0.3, le=MAX_SLEEPER_GAP)

    @model_validator(mode="after")
    def _measured(self):
        keys = ("stiffness_load_kN", "curve_shape", "stiffness_between", "sleeper_spacing_m")
        given = [k for k in keys if getattr(self, k) != SupportsFormat.model_fields[k].default]
        if self.supports_kind == "curves" and given:
            raise ValueError(f"{', '.join(sorted(given))}: for supports_kind = 'measured'")
        if self.supports_kind == "measured" and self.stiffness_load_kN is None:
            raise ValueError("supports_kind = 'measured' needs stiffness_load_kN, the wheel "
                             "load at which the stiffness was measured")  # fmt: skip
        return self


def _sleeper_where(source: str, position, i: int) -> str:
    """Where sleeper ``i`` of supports made of a measured stiffness is."""
    return f"{source}, sleeper at {position[i]:g} m (of the measured stiffness)"


def sleeper_positions(start: float, end: float, spacing: float) -> np.ndarray:
    """Sleepers ``spacing`` apart from half a spacing after ``start`` to ``end`` [m]."""
    count = int(np.floor((end - start) / spacing - 0.5)) + 1
    return start + spacing * (0.5 + np.arange(max(count, 0)))


def at_sleepers(distance, stiffness, position, rule: str) -> np.ndarray:
    """A stiffness measured at ``distance`` taken to the sleeper ``position``s by ``rule``
    (``"linear"`` or ``"nearest"``), the end values held beyond the ends [N/m]."""
    if rule == "linear":
        return np.interp(position, distance, stiffness)
    right = np.clip(np.searchsorted(distance, position), 1, max(distance.size - 1, 1))
    left = right - 1
    nearer = np.abs(position - distance[left]) <= np.abs(distance[right] - position)
    return stiffness[np.where(nearer, left, right)]


def scaled_curves(shape: SupportCurve, stiffness, load: float, where) -> Curves:
    """Curves of ``shape`` scaled in deflection, one per ``stiffness`` [N/m], so that each
    has that secant stiffness at ``load`` [N]."""
    reference = float(shape.deflection_at(load))
    factor = (load / np.asarray(stiffness, dtype=float)) / reference
    n = factor.size
    return Curves(
        np.tile(shape.load, n),
        (factor[:, None] * shape.deflection[None, :]).reshape(-1),
        np.arange(0, shape.load.size * n + 1, shape.load.size),
        where,
    )


def measured_supports(measured, fmt: SupportsFormat, span, shape: SupportCurve, source) -> Supports:
    """Per-sleeper supports of a measured track stiffness (module docstring).

    Parameters
    ----------
    measured : dict
        Per rail (``"left"``, ``"right"``): ``(distance [m], stiffness [N/m], lines)``,
        distances strictly increasing, ``lines`` the file's line of each row.
    fmt : SupportsFormat
        The stated load, shape, rule and spacing.
    span : tuple of float
        First and last distance of the geometry [m]: where the sleepers go.
    shape : SupportCurve
        The ``example`` shape (ignored for ``linear``).
    source : str or Path
        The file, named in messages.
    """
    assert fmt.stiffness_load_kN is not None
    load = fmt.stiffness_load_kN * 1e3
    if fmt.curve_shape == "example" and not shape.load[0] < load <= shape.load[-1]:
        raise TrackdynInputError(
            f"{source}: stiffness_load_kN = {fmt.stiffness_load_kN:g} kN is outside the example "
            f"curve shape's loads (up to {shape.load[-1] / 1e3:g} kN); give curve_shape = "
            "'linear'"
        )
    position = sleeper_positions(span[0], span[1], fmt.sleeper_spacing_m)
    rails = {}
    for rail in RAILS:
        distance, stiffness, lines = measured[rail]
        lo, hi = SUPPORT_STIFFNESS
        bad = np.flatnonzero(~((stiffness >= lo) & (stiffness <= hi)))
        if bad.size:
            i = bad[0]
            raise TrackdynInputError(
                f"{source}: line {lines[i]}: the {rail} rail's stiffness is "
                f"{stiffness[i] / 1e6:g} kN/mm, outside the plausible {lo / 1e6:g} to "
                f"{hi / 1e6:g} kN/mm"
            )
        k = at_sleepers(distance, stiffness, position, fmt.stiffness_between)
        where = functools.partial(_sleeper_where, f"{source}: {rail} rail", position)
        rails[rail] = (
            Curves.linear(k, where)
            if fmt.curve_shape == "linear"
            else scaled_curves(shape, k, load, where)
        )
    return Supports(position, rails["left"], rails["right"], str(source))
