"""The 11-DOF assembly against eqs 5.19-5.33 of the seed, typed out term by term.

Each equation of motion 5.19-5.29 is entered below as printed, one term per line, into
matrices in the seed's own variable order (y1, θ, α, yF, φF, yB, φB, zF, ωF, zB, ωB),
with the equation number as the row. The result is then permuted to the model's
``dof_names`` and compared with the assembled ``M, K, C, Dw, Dc``. Only the vehicle
parameter values come from the package (the ``loaded`` preset); every coefficient is
rebuilt here from them.
"""

import numpy as np
import pytest

from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import load_vehicle

RTOL = 1e-12

# Seed variable order (5.19-5.29: the equations are for these coordinates in this order).
SEED_VARS = ("y1", "th", "al", "yF", "phF", "yB", "phB", "zF", "omF", "zB", "omB")
Y1, TH, AL, YF, PHF, YB, PHB, ZF, OMF, ZB, OMB = range(11)
# The same coordinates as the model names them (models.py docstring: y1, θ, α, yF, φF, ...).
SEED_TO_MODEL = {
    "y1": "body_bounce",
    "th": "body_roll",
    "al": "body_pitch",
    "yF": "front_bogie_bounce",
    "phF": "front_bogie_roll",
    "yB": "back_bogie_bounce",
    "phB": "back_bogie_roll",
    "zF": "front_wheelset_bounce",
    "omF": "front_wheelset_roll",
    "zB": "back_wheelset_bounce",
    "omB": "back_wheelset_roll",
}
WEDGES = ("FL", "FR", "BL", "BR")
FL, FR, BL, BR = range(4)
# Distinct track stiffnesses [N/m] and loaded profiles [m] per contact, arbitrary test
# values: distinct so that a term attached to the wrong contact cannot go unnoticed.
K2 = {"FL": 1.7e8, "FR": 2.3e8, "BL": 1.1e8, "BR": 2.9e8}
YI = {"FL": 1.3e-3, "FR": -0.7e-3, "BL": 2.1e-3, "BR": 0.4e-3}


def seed_matrices(v, k2):
    """Eqs 5.19-5.29 as printed, as arrays in the seed's variable order.

    Returns ``M, C, K`` (K: the k1, kp terms), ``Fc`` (11 x 4: coefficients of F_FL..F_BR),
    ``K2`` (the k2 terms multiplying the coordinates) and ``Yi`` (11 x 4: coefficients of
    the track inputs y_FLi..y_BRi).
    """
    m1, I1, Ip, m2, I2, mw, Iw = v.m1, v.I1, v.Ip, v.m2, v.I2, v.mw, v.Iw
    k1, kp, rp, r2 = v.k1, v.kp, v.rho_p, v.rho2
    b, bcc, l = v.b, v.b_cc, v.l  # noqa: E741 - the seed's symbol
    k2FL, k2FR, k2BL, k2BR = k2["FL"], k2["FR"], k2["BL"], k2["BR"]
    M, C, K, K2m = (np.zeros((11, 11)) for _ in range(4))
    Fc, Yi = np.zeros((11, 4)), np.zeros((11, 4))

    # (5.19) m1 y1'' + F_FL + F_FR + F_BL + F_BR + 4k1 y1 - 2k1 yF - 2k1 yB = 0
    e = Y1
    M[e, Y1] += m1
    Fc[e, FL] += 1
    Fc[e, FR] += 1
    Fc[e, BL] += 1
    Fc[e, BR] += 1
    K[e, Y1] += 4 * k1
    K[e, YF] += -2 * k1
    K[e, YB] += -2 * k1

    # (5.20) I1 θ'' + bF_FL - bF_FR + bF_BL - bF_BR + 4b²k1 θ - 2b²k1 φF - 2b²k1 φB = 0
    e = TH
    M[e, TH] += I1
    Fc[e, FL] += b
    Fc[e, FR] += -b
    Fc[e, BL] += b
    Fc[e, BR] += -b
    K[e, TH] += 4 * b**2 * k1
    K[e, PHF] += -2 * b**2 * k1
    K[e, PHB] += -2 * b**2 * k1

    # (5.21) Ip α'' - bcc F_FL - bcc F_FR + bcc F_BL + bcc F_BR + 4bcc² k1 α
    #        + 2bcc k1 yF - 2bcc k1 yB = 0
    e = AL
    M[e, AL] += Ip
    Fc[e, FL] += -bcc
    Fc[e, FR] += -bcc
    Fc[e, BL] += bcc
    Fc[e, BR] += bcc
    K[e, AL] += 4 * bcc**2 * k1
    K[e, YF] += 2 * bcc * k1
    K[e, YB] += -2 * bcc * k1

    # (5.22) m2 yF'' - F_FL - F_FR + 2ρp yF' - 2k1 (y1 - yF) + 2kp (yF - zF) + 2k1 bcc α
    #        - 2ρp zF' = 0
    e = YF
    M[e, YF] += m2
    Fc[e, FL] += -1
    Fc[e, FR] += -1
    C[e, YF] += 2 * rp
    K[e, Y1] += -2 * k1
    K[e, YF] += 2 * k1
    K[e, YF] += 2 * kp
    K[e, ZF] += -2 * kp
    K[e, AL] += 2 * k1 * bcc
    C[e, ZF] += -2 * rp

    # (5.23) I2 φF'' - bF_FL + bF_FR + 2b²ρp φF' - 2bk1 (bθ - bφF) + 2b²kp φF - 2b²ρp ωF'
    #        - 2b²kp ωF = 0
    e = PHF
    M[e, PHF] += I2
    Fc[e, FL] += -b
    Fc[e, FR] += b
    C[e, PHF] += 2 * b**2 * rp
    K[e, TH] += -2 * b * k1 * b
    K[e, PHF] += 2 * b * k1 * b
    K[e, PHF] += 2 * b**2 * kp
    C[e, OMF] += -2 * b**2 * rp
    K[e, OMF] += -2 * b**2 * kp

    # (5.24) m2 yB'' - F_BL - F_BR + 2ρp yB' - 2k1 (y1 - yB) + 2kp (yB - zB) - 2k1 bcc α
    #        - 2ρp zB' = 0
    e = YB
    M[e, YB] += m2
    Fc[e, BL] += -1
    Fc[e, BR] += -1
    C[e, YB] += 2 * rp
    K[e, Y1] += -2 * k1
    K[e, YB] += 2 * k1
    K[e, YB] += 2 * kp
    K[e, ZB] += -2 * kp
    K[e, AL] += -2 * k1 * bcc
    C[e, ZB] += -2 * rp

    # (5.25) I2 φB'' - bF_BL + bF_BR + 2b²ρp φB' - 2bk1 (bθ - bφB) + 2b²kp φB - 2b²ρp ωB'
    #        - 2b²kp ωB = 0
    e = PHB
    M[e, PHB] += I2
    Fc[e, BL] += -b
    Fc[e, BR] += b
    C[e, PHB] += 2 * b**2 * rp
    K[e, TH] += -2 * b * k1 * b
    K[e, PHB] += 2 * b * k1 * b
    K[e, PHB] += 2 * b**2 * kp
    C[e, OMB] += -2 * b**2 * rp
    K[e, OMB] += -2 * b**2 * kp

    # (5.26) mw zF'' + 2(ρp + ρ2) zF' + 2kp zF + k2FL zF + k2FR zF - 2ρp yF' - 2kp yF
    #        - k2FL yFLi - k2FR yFRi + k2FL l ωF - k2FR l ωF = 0
    e = ZF
    M[e, ZF] += mw
    C[e, ZF] += 2 * (rp + r2)
    K[e, ZF] += 2 * kp
    K2m[e, ZF] += k2FL
    K2m[e, ZF] += k2FR
    C[e, YF] += -2 * rp
    K[e, YF] += -2 * kp
    Yi[e, FL] += -k2FL
    Yi[e, FR] += -k2FR
    K2m[e, OMF] += k2FL * l
    K2m[e, OMF] += -k2FR * l

    # (5.27) Iw ωF'' + 2(b²ρp + l²ρ2) ωF' + 2b²kp ωF + k2FL l² ωF + k2FR l² ωF - 2ρp b² φF'
    #        - 2kp b² φF - k2FL l yFLi + k2FR l yFRi + k2FL l zF - k2FR l zF = 0
    e = OMF
    M[e, OMF] += Iw
    C[e, OMF] += 2 * (b**2 * rp + l**2 * r2)
    K[e, OMF] += 2 * b**2 * kp
    K2m[e, OMF] += k2FL * l**2
    K2m[e, OMF] += k2FR * l**2
    C[e, PHF] += -2 * rp * b**2
    K[e, PHF] += -2 * kp * b**2
    Yi[e, FL] += -k2FL * l
    Yi[e, FR] += k2FR * l
    K2m[e, ZF] += k2FL * l
    K2m[e, ZF] += -k2FR * l

    # (5.28) mw zB'' + 2(ρp + ρ2) zB' + 2kp zB + k2BL zB + k2BR zB - 2ρp yB' - 2kp yB
    #        - k2BL yBLi - k2BR yBRi + k2BL l ωB - k2BR l ωB = 0
    e = ZB
    M[e, ZB] += mw
    C[e, ZB] += 2 * (rp + r2)
    K[e, ZB] += 2 * kp
    K2m[e, ZB] += k2BL
    K2m[e, ZB] += k2BR
    C[e, YB] += -2 * rp
    K[e, YB] += -2 * kp
    Yi[e, BL] += -k2BL
    Yi[e, BR] += -k2BR
    K2m[e, OMB] += k2BL * l
    K2m[e, OMB] += -k2BR * l

    # (5.29) Iw ωB'' + 2(b²ρp + l²ρ2) ωB' + 2b²kp ωB + k2BL l² ωB + k2BR l² ωB - 2ρp b² φB'
    #        - 2kp b² φB - k2BL l yBLi + k2BR l yBRi + k2BL l zB - k2BR l zB = 0
    e = OMB
    M[e, OMB] += Iw
    C[e, OMB] += 2 * (b**2 * rp + l**2 * r2)
    K[e, OMB] += 2 * b**2 * kp
    K2m[e, OMB] += k2BL * l**2
    K2m[e, OMB] += k2BR * l**2
    C[e, PHB] += -2 * rp * b**2
    K[e, PHB] += -2 * kp * b**2
    Yi[e, BL] += -k2BL * l
    Yi[e, BR] += k2BR * l
    K2m[e, ZB] += k2BL * l
    K2m[e, ZB] += -k2BR * l

    return M, C, K, Fc, K2m, Yi


def seed_relative_displacements(v):
    """The displacement across each secondary suspension, 5.30-5.33, seed variable order.

    FL: y1 - yF + bθ - bφF - bcc α;  FR: y1 - yF - bθ + bφF - bcc α;
    BL: y1 - yB + bθ - bφB + bcc α;  BR: y1 - yB - bθ + bφB + bcc α.
    """
    b, bcc = v.b, v.b_cc
    D = np.zeros((4, 11))
    D[FL, [Y1, YF, TH, PHF, AL]] = [1, -1, b, -b, -bcc]
    D[FR, [Y1, YF, TH, PHF, AL]] = [1, -1, -b, b, -bcc]
    D[BL, [Y1, YB, TH, PHB, AL]] = [1, -1, b, -b, bcc]
    D[BR, [Y1, YB, TH, PHB, AL]] = [1, -1, -b, b, bcc]
    return D


@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("loaded")


@pytest.fixture(scope="module")
def model(vehicle):
    return build_model("11dof", vehicle)


@pytest.fixture(scope="module")
def perm(model):
    """Index into the model's coordinates of each seed coordinate."""
    assert sorted(model.dof_names) == sorted(SEED_TO_MODEL.values())
    return np.array([model.dof_names.index(SEED_TO_MODEL[s]) for s in SEED_VARS])


@pytest.fixture(scope="module")
def seed(vehicle):
    return seed_matrices(vehicle, K2)


def to_model(a, perm):
    """Seed-order square matrix -> model order."""
    out = np.empty_like(a)
    out[np.ix_(perm, perm)] = a
    return out


def rows_to_model(a, perm):
    """Seed-order rows (equations) -> model order, for an (11, n) array."""
    out = np.empty_like(a)
    out[perm] = a
    return out


def test_dof_order_is_the_documented_one(model):
    # Order stated in the brief / models.py: body, front bogie, front wheelset, back ...
    assert model.dof_names == (
        "body_bounce",
        "body_roll",
        "body_pitch",
        "front_bogie_bounce",
        "front_bogie_roll",
        "front_wheelset_bounce",
        "front_wheelset_roll",
        "back_bogie_bounce",
        "back_bogie_roll",
        "back_wheelset_bounce",
        "back_wheelset_roll",
    )
    assert model.wedge_names == WEDGES
    assert model.contact_names == WEDGES
    assert model.contact_rails == ("left", "right", "left", "right")


def test_mass_matrix(model, seed, perm):
    M = seed[0]
    np.testing.assert_allclose(model.M, to_model(M, perm), rtol=RTOL, atol=0)


def test_spring_stiffness_matrix(model, seed, perm):
    # K of the model holds the suspension springs only (k1, kp terms of 5.19-5.29).
    K = seed[2]
    np.testing.assert_allclose(model.K, to_model(K, perm), rtol=RTOL, atol=0)


def test_damping_matrix(model, seed, perm):
    # C holds the primary dampers and the track damping ρ2 (5.22-5.29); no secondary
    # viscous damper in the 11-DOF model (the wedges are the secondary damping).
    C = seed[1]
    np.testing.assert_allclose(model.C, to_model(C, perm), rtol=RTOL, atol=0)


def test_friction_force_coefficients_are_dw_transpose(model, seed, perm):
    # Columns multiplying F_FL..F_BR in 5.19-5.25 (zero in 5.26-5.29) equal Dw^T.
    Fc = seed[3]
    np.testing.assert_allclose(model.Dw.T, rows_to_model(Fc, perm), rtol=RTOL, atol=0)


def test_relative_displacements_are_dw_rows(model, vehicle, perm):
    # 5.30-5.33: the argument of each friction law (and, differentiated, its velocity).
    D = seed_relative_displacements(vehicle)
    np.testing.assert_allclose(model.Dw[:, perm], D, rtol=RTOL, atol=0)


def test_friction_force_map_is_the_relative_displacement_transpose(vehicle):
    # Virtual work: the force F acting across the suspension whose compression is D q
    # enters the equations as D^T F; the printed 5.19-5.25 and 5.30-5.33 agree on that.
    _, _, _, Fc, _, _ = seed_matrices(vehicle, K2)
    np.testing.assert_allclose(Fc, seed_relative_displacements(vehicle).T, rtol=RTOL, atol=0)


def test_contact_stiffness_coupling(model, seed, perm):
    # k2 terms of 5.26-5.29 multiplying the coordinates equal Dc^T diag(k) Dc.
    K2m = seed[4]
    k = np.array([K2[c] for c in model.contact_names])
    np.testing.assert_allclose(
        model.Dc.T @ (k[:, None] * model.Dc), to_model(K2m, perm), rtol=RTOL, atol=0
    )


def test_contact_input_coupling(model, seed, perm):
    # k2 y_i terms of 5.26-5.29 (moved to the right-hand side) equal Dc^T diag(k) r.
    Yi = seed[5]
    k = np.array([K2[c] for c in model.contact_names])
    r = np.array([YI[c] for c in model.contact_names])
    seed_rhs = -rows_to_model(Yi, perm) @ np.array([YI[w] for w in WEDGES])
    np.testing.assert_allclose(model.Dc.T @ (k * r), seed_rhs, rtol=RTOL, atol=0)


@pytest.mark.parametrize("contact", WEDGES)
def test_each_contact_alone(vehicle, model, perm, contact):
    # One contact stiff, the others zero: its k2 terms are k outer(Dc_c, Dc_c), so a term
    # booked on the wrong contact (e.g. FL for FR) shows up even if the sums agreed.
    k2 = dict.fromkeys(WEDGES, 0.0) | {contact: 1.0}
    _, _, _, _, K2m, Yi = seed_matrices(vehicle, k2)
    c = model.contact_names.index(contact)
    row = model.Dc[c]
    np.testing.assert_allclose(np.outer(row, row), to_model(K2m, perm), rtol=RTOL, atol=1e-15)
    np.testing.assert_allclose(-row, rows_to_model(Yi, perm)[:, WEDGES.index(contact)])


def test_contact_damping_is_rho2_per_contact(model, vehicle):
    # 5.26-5.29: 2ρ2 on zF (one ρ2 per side of a bogie) and 2 l² ρ2 on ωF.
    np.testing.assert_allclose(model.contact_damping, np.full(4, vehicle.rho2), rtol=RTOL)


def test_wedge_parameters(model, vehicle):
    # 5.30-5.33 use the same k_ss, x_ss, μ, tan α_w and C_slope for all four wedges.
    expected = [vehicle.k_ss, vehicle.x_ss, vehicle.mu, np.tan(vehicle.alpha_w), vehicle.C_slope]
    np.testing.assert_allclose(model.wedge_params, np.tile(expected, (4, 1)), rtol=RTOL)


def test_stiffness_and_damping_symmetric(model):
    # seed-notes.md: the stiffness and damping matrices of 5.19-5.29 are symmetric.
    np.testing.assert_allclose(model.K, model.K.T, rtol=0, atol=1e-14 * np.abs(model.K).max())
    np.testing.assert_allclose(model.C, model.C.T, rtol=0, atol=1e-14 * np.abs(model.C).max())


def test_seed_matrices_symmetric(vehicle):
    # The same property of the equations as printed: guards the hand transcription above.
    M, C, K, Fc, K2m, _ = seed_matrices(vehicle, K2)
    for a in (C, K, K2m):
        np.testing.assert_allclose(a, a.T, rtol=RTOL, atol=0)


def rigid_modes(model, v):
    """Rigid-body motions of the whole vehicle off the track (geometry of 5.30-5.33)."""
    names = model.dof_names
    bounce = np.array([1.0 if n.endswith("bounce") else 0.0 for n in names])
    roll = np.array([1.0 if n.endswith("roll") else 0.0 for n in names])
    # Pitch by α: body pitch α, bodies over the front bogie (x = +bcc) go down by -bcc α,
    # over the back bogie by +bcc α (displacement = bounce - x α).
    pitch = np.zeros(len(names))
    pitch[names.index("body_pitch")] = 1.0
    for n in names:
        if n.endswith("bounce") and not n.startswith("body"):
            pitch[names.index(n)] = -v.b_cc if n.startswith("front") else v.b_cc
    return bounce, roll, pitch


def test_stiffness_has_rigid_body_modes(model, vehicle):
    # Uniform bounce (and roll, and pitch) of all bodies stretches no spring.
    scale = np.abs(model.K).max()
    for mode in rigid_modes(model, vehicle):
        np.testing.assert_allclose(model.K @ mode, 0.0, atol=1e-12 * scale)
        np.testing.assert_allclose(model.Dw @ mode, 0.0, atol=1e-15)
    # ... and nothing else does: 11 coordinates, 8 springs-and-suspension modes.
    assert np.linalg.matrix_rank(model.K) == 8


def test_contacts_remove_the_rigid_body_modes(model):
    # With the track (any positive k2) the system is statically determinate: K + K_track > 0.
    k = np.array([K2[c] for c in model.contact_names])
    Kt = model.K + model.Dc.T @ (k[:, None] * model.Dc)
    assert np.linalg.eigvalsh(Kt).min() > 0


def test_two_dof_matrices(vehicle):
    # 5.12-5.13 with the brief's lumping: m1/8 on (mw + m2)/4, spring k1/2, damper ρ1,
    # track damping ρ2 on the wheel.
    m = build_model("2dof", vehicle)
    v = vehicle
    assert m.dof_names == ("body_bounce", "wheel_bounce")
    np.testing.assert_allclose(m.M, np.diag([v.m1 / 8, (v.mw + v.m2) / 4]), rtol=RTOL)
    k1, r1, r2 = v.k1 / 2, v.rho1, v.rho2
    # (5.12) m1 y1'' + ρ1 y1' + k1 y1 - ρ1 y2' - k1 y2 = 0
    # (5.13) mw y2'' + (ρ1 + ρ2) y2' + (k1 + k2) y2 - ρ1 y1' - k1 y1 - k2 y0 = 0
    np.testing.assert_allclose(m.K, [[k1, -k1], [-k1, k1]], rtol=RTOL)
    np.testing.assert_allclose(m.C, [[r1, -r1], [-r1, r1 + r2]], rtol=RTOL)
    np.testing.assert_allclose(m.Dc, [[0.0, 1.0]], rtol=RTOL)
    assert m.Dw.shape == (0, 2)
