"""The seed's models (2-, 4-, 7- and 11-DOF) as assemblies of one vehicle parameter set.

Coordinates (positive down): body bounce ``y1``, roll ``θ``, pitch ``α``; bogie frame
bounce ``yF, yB`` and roll ``φF, φB``; lumped wheelset bounce ``zF, zB`` and roll
``ωF, ωB``. The 4- and 7-DOF models have no primary suspension (5.4.2: it arrives with the
11-DOF model), so the bogie frame moves with the wheelset and its mass and roll inertia
are lumped into it. All bogie models use the bogie approximation of 5.4.3.
"""

from __future__ import annotations

from trackdyn.errors import TrackdynInputError
from trackdyn.vehicle.assembly import Assembly, Body, Contact, Damper, Model, Point, Spring, Wedge
from trackdyn.vehicle.parameters import Vehicle

GROUND = Point(None)
SIDES = (("L", 1.0, "left"), ("R", -1.0, "right"))


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
    return asm.build("2dof-wedge" if wedge else "2dof", v.static_wheel_load)


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
    return asm.build("4dof", v.static_wheel_load)


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
    return asm.build("7dof", v.static_wheel_load)


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
    return asm.build("11dof", v.static_wheel_load)


def two_dof_wedge(v: Vehicle) -> Model:
    """The 2-DOF model with half a side's friction wedge in place of the viscous damper."""
    return two_dof(v, wedge=True)


MODELS = {
    "2dof": two_dof,
    "2dof-wedge": two_dof_wedge,
    "4dof": four_dof,
    "7dof": seven_dof,
    "11dof": eleven_dof,
}
"""The models by name: the one list that validators, help texts and errors derive from."""


def build_model(name: str, vehicle: Vehicle) -> Model:
    """Build a model by name, a key of `MODELS`."""
    if name not in MODELS:
        raise TrackdynInputError(f"unknown model {name!r}; known: {', '.join(MODELS)}")
    return MODELS[name](vehicle)
