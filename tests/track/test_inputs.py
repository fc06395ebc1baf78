"""A model's contact input is `LinearisedTrack.sample` of each of its axles, summed per
contact as `ContactInput` weights them: the compiled sampling does numpy's and scipy's
operations in their order, so the values are the same to the bit."""

import numpy as np
import pytest

from trackdyn.track.inputs import ContactInput
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import load_vehicle


@pytest.mark.parametrize("model", ["2dof", "11dof", "full"])
def test_contact_input_is_the_sampled_track(lin, model):
    m = build_model(model, load_vehicle("loaded"))
    inputs = ContactInput(m, lin)
    lo, hi = lin.track.extent
    reach = [x for axles in m.contact_axles for x in axles]
    # positions between sleepers, on sleepers (the last ones too) and on the geometry's
    # knots, in order: the sampling goes in runs between sleepers and knots
    sleepers, knots = lin.track.supports.position, lin.track.geometry.distance
    centre = np.sort(np.r_[np.linspace(lo - min(reach), hi - max(reach), 3001),
                           sleepers[20:30] - reach[0], knots[40:60] - reach[-1],
                           sleepers[-3:] - max(reach)])  # fmt: skip
    centre = centre[(centre + min(reach) >= lo) & (centre + max(reach) <= hi)]
    k, r = inputs.linear(centre)
    for c, (rail, axles) in enumerate(zip(m.contact_rails, m.contact_axles, strict=True)):
        want_k, want_r = np.zeros(centre.size), np.zeros(centre.size)
        for x in axles:
            kk, rr = lin.sample(rail, centre + x)
            want_k += kk
            want_r += rr * (1.0 / len(axles))
        np.testing.assert_array_equal(k[:, c], want_k)
        np.testing.assert_array_equal(r[:, c], want_r)


def test_contact_input_of_positions_out_of_order(lin):
    # the sampling goes in runs of positions that do not go back: positions in any order
    # give what each gives on its own
    m = build_model("11dof", load_vehicle("loaded"))
    inputs = ContactInput(m, lin)
    lo, hi = lin.track.extent
    reach = [x for axles in m.contact_axles for x in axles]
    centre = np.random.default_rng(2).uniform(lo - min(reach), hi - max(reach), 400)
    k, r = inputs.linear(centre)
    for i in (0, 1, 57, 399):
        k1, r1 = inputs.linear(centre[i : i + 1])
        np.testing.assert_array_equal(k[i], k1[0])
        np.testing.assert_array_equal(r[i], r1[0])
    order = np.argsort(centre)
    ks, rs = inputs.linear(centre[order])
    np.testing.assert_array_equal(ks, k[order])
    np.testing.assert_array_equal(rs, r[order])
