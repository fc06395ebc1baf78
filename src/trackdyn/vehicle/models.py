"""The thesis's models (2-, 4-, 7- and 11-DOF) and the full model, from one parameter set.

Coordinates (positive down): body bounce ``y1``, roll ``θ``, pitch ``α``; bogie frame
bounce ``yF, yB`` and roll ``φF, φB``; lumped wheelset bounce ``zF, zB`` and roll
``ωF, ωB``. The 4- and 7-DOF models have no primary suspension (5.4.2: it arrives with the
11-DOF model), so the bogie frame moves with the wheelset and its mass and roll inertia
are lumped into it. These bogie models use the bogie approximation of 5.4.3.

The full model is the one the thesis checked that approximation against (5.4.3: a
multibody model "in which the side frames of the bogies were modelled as separate
bodies"): per bogie two side frames (bounce, pitch) and two wheelsets (bounce, roll), one
contact per wheel (19 degrees of freedom, 8 contacts). See `full`.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria. Chapter 5,
eqs 5.12-5.33.
"""

from __future__ import annotations

from trackdyn.errors import unknown
from trackdyn.vehicle.assembly import Assembly, Body, Contact, Damper, Model, Point, Spring, Wedge
from trackdyn.vehicle.parameters import Vehicle

SIDES = (("L", 1.0, "left"), ("R", -1.0, "right"))

AXLES_PER_RAIL = 4
"""Wheels on each rail of the vehicles the parameter sets describe: two bogies of two
axles (`trackdyn.vehicle.parameters`)."""


def _build(asm: Assembly, name: str, v: Vehicle) -> Model:
    """The model of a bogie vehicle ``v``: `AXLES_PER_RAIL` axles, ``m1 + 2 m2 + 2 mw``."""
    return asm.build(name, v.static_wheel_load, AXLES_PER_RAIL, v.m1 + 2 * v.m2 + 2 * v.mw)


def _wedge(v: Vehicle, name: str, p: Point, q: Point, scale: float = 1.0) -> Wedge:
    return Wedge(name, p, q, v.k_ss * scale, v.x_ss, v.mu, v.alpha_w, v.C_slope * scale)


def two_dof(v: Vehicle, wedge: bool = False) -> Model:
    """Eqs 5.12-5.13: one eighth of the body on one wheel, viscous secondary damping.

    Body mass ``m1/8``; wheel mass ``(mw + m2)/4`` (no primary suspension); secondary
    stiffness ``k1/2`` and viscous damping ``rho1``, or with ``wedge`` half a side's
    friction wedge (Appendix B uses the wedge law of 5.30) in place of ``rho1``.
    """
    asm = Assembly()
    body = asm.add(Body("body", v.m1 / 8))
    wheel = asm.add(Body("wheel", (v.mw + v.m2) / 4))
    asm.add(Spring(body.at(), wheel.at(), v.k1 / 2, "secondary"))
    if wedge:
        asm.add(_wedge(v, "secondary", body.at(), wheel.at(), scale=0.5))
    else:
        asm.add(Damper(body.at(), wheel.at(), v.rho1))
    asm.add(Contact("wheel", wheel.at(), "left", (v.b_cc + v.a,), v.rho2))
    return _build(asm, "2dof-wedge" if wedge else "2dof", v)


def _bogie_side_contacts(asm, v, wheelset, prefix, centre):
    for side, sign, rail in SIDES:
        axles = (centre + v.a, centre - v.a)
        asm.add(Contact(prefix + side, wheelset.at(sign * v.l), rail, axles, v.rho2))


def four_dof(v: Vehicle) -> Model:
    """Body and wheelset bounce and roll: half the body on one (front) lumped bogie."""
    asm = Assembly()
    body = asm.add(Body("body", v.m1 / 2, roll_inertia=v.I1 / 2, motions=("bounce", "roll")))
    ws = asm.add(
        Body("wheelset", v.mw + v.m2, roll_inertia=v.Iw + v.I2, motions=("bounce", "roll"))
    )
    for side, sign, _ in SIDES:
        asm.add(Spring(body.at(sign * v.b), ws.at(sign * v.b), v.k1, side))
        asm.add(_wedge(v, side, body.at(sign * v.b), ws.at(sign * v.b)))
    _bogie_side_contacts(asm, v, ws, "", v.b_cc)
    return _build(asm, "4dof", v)


def seven_dof(v: Vehicle) -> Model:
    """Body bounce, roll, pitch; front and back lumped wheelsets, bounce and roll."""
    asm = Assembly()
    body = asm.add(Body("body", v.m1, v.I1, v.Ip, ("bounce", "roll", "pitch")))
    for end, x in (("front", v.b_cc), ("back", -v.b_cc)):
        ws = asm.add(
            Body(
                f"{end}_wheelset", v.mw + v.m2, roll_inertia=v.Iw + v.I2, motions=("bounce", "roll")
            )
        )
        for side, sign, _ in SIDES:
            p = body.at(sign * v.b, x)
            name = end[0].upper() + side
            asm.add(Spring(p, ws.at(sign * v.b), v.k1, name))
            asm.add(_wedge(v, name, p, ws.at(sign * v.b)))
        _bogie_side_contacts(asm, v, ws, end[0].upper(), x)
    return _build(asm, "7dof", v)


def eleven_dof(v: Vehicle) -> Model:
    """Eqs 5.19-5.33: adds the bogie frames and the primary suspension."""
    asm = Assembly()
    body = asm.add(Body("body", v.m1, v.I1, v.Ip, ("bounce", "roll", "pitch")))
    for end, x in (("front", v.b_cc), ("back", -v.b_cc)):
        frame = asm.add(Body(f"{end}_bogie", v.m2, roll_inertia=v.I2, motions=("bounce", "roll")))
        ws = asm.add(Body(f"{end}_wheelset", v.mw, roll_inertia=v.Iw, motions=("bounce", "roll")))
        for side, sign, _ in SIDES:
            p = body.at(sign * v.b, x)
            name = end[0].upper() + side
            asm.add(Spring(p, frame.at(sign * v.b), v.k1, name))
            asm.add(_wedge(v, name, p, frame.at(sign * v.b)))
            asm.add(Spring(frame.at(sign * v.b), ws.at(sign * v.b), v.kp))
            asm.add(Damper(frame.at(sign * v.b), ws.at(sign * v.b), v.rho_p))
        _bogie_side_contacts(asm, v, ws, end[0].upper(), x)
    return _build(asm, "11dof", v)


def full(v: Vehicle) -> Model:
    """Side frames and wheelsets as separate bodies, one contact per wheel.

    Bodies: the car body (bounce, roll, pitch; the bolsters lumped in as in the 11-DOF
    model); per bogie (``front`` at ``+b_cc``, ``back`` at ``-b_cc``) a ``left`` and a
    ``right`` side frame of mass ``m2 / 2`` and pitch inertia ``Isf`` (bounce and pitch,
    at ``±b``: together the bogie frame roll inertia ``m2 b²``, which the presets' ``I2``
    equals); per bogie a leading and a trailing wheelset of mass ``mw1`` and roll inertia
    ``Iw1`` (bounce and roll), numbered 1-4 from the front.

    Elements: per bogie side the secondary spring ``k1`` and the friction wedge (5.30-5.33)
    between the body at ``(±b, ±b_cc)`` and the side frame's centre (suspensions and
    wedges ``FL, FR, BL, BR`` as in the 11-DOF model); per axlebox (side frame at ``±a``
    from its centre to the wheelset at ``±b``) half the per-side primary ``kp / 2`` and
    ``rho_p / 2``; per wheel (at ``±l``) a contact ``1L .. 4R`` on its own rail at its own
    axle (``±b_cc ± a``) with track damping ``rho2`` and the track stiffness and input
    under that wheel alone, so the nonlinear track of 5.14 applies per wheel.

    With the same input under both axles of a bogie the two wheelsets move alike, the side
    frames do not pitch and the model is the 11-DOF model with track damping ``2 rho2``
    per bogie side: the printed 5.26-5.29 give one ``rho2`` per two wheels (the contacts
    of the 11-DOF model sum the stiffness of the two axles, not their damping).
    """
    asm = Assembly()
    body = asm.add(Body("body", v.m1, v.I1, v.Ip, ("bounce", "roll", "pitch")))
    axle = 0
    for end, x in (("front", v.b_cc), ("back", -v.b_cc)):
        frames = {
            side: asm.add(
                Body(
                    f"{end}_{rail}_frame",
                    v.m2 / 2,
                    pitch_inertia=v.Isf,
                    motions=("bounce", "pitch"),
                )
            )
            for side, _, rail in SIDES
        }
        for lead in (v.a, -v.a):
            axle += 1
            ws = asm.add(
                Body(f"wheelset_{axle}", v.mw1, roll_inertia=v.Iw1, motions=("bounce", "roll"))
            )
            for side, sign, rail in SIDES:
                box, wheel = frames[side].at(sign * v.b, lead), ws.at(sign * v.b)
                asm.add(Spring(box, wheel, v.kp / 2))
                asm.add(Damper(box, wheel, v.rho_p / 2))
                name = end[0].upper() + side
                asm.add(
                    Contact(f"{axle}{side}", ws.at(sign * v.l), rail, (x + lead,), v.rho2, name)
                )
        for side, sign, _ in SIDES:
            p, name = body.at(sign * v.b, x), end[0].upper() + side
            asm.add(Spring(p, frames[side].at(sign * v.b), v.k1, name))
            asm.add(_wedge(v, name, p, frames[side].at(sign * v.b)))
    return _build(asm, "full", v)


def two_dof_wedge(v: Vehicle) -> Model:
    """The 2-DOF model with half a side's friction wedge in place of the viscous damper."""
    return two_dof(v, wedge=True)


MODELS = {
    "2dof": two_dof,
    "2dof-wedge": two_dof_wedge,
    "4dof": four_dof,
    "7dof": seven_dof,
    "11dof": eleven_dof,
    "full": full,
}
"""The models by name: the one list that validators, help texts and errors derive from."""


def build_model(name: str, vehicle: Vehicle) -> Model:
    """Build a model by name, a key of `MODELS`."""
    if name not in MODELS:
        raise unknown("model", name, MODELS)
    return MODELS[name](vehicle)
