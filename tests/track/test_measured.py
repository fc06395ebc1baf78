"""Supports made of a measured track stiffness: the stated rules, checked by their closed
forms, and a run on them against the run on the curves they were measured from."""

import numpy as np
import pandas as pd
import pytest

from trackdyn import RunOptions, load_track, load_vehicle, simulate
from trackdyn.data import EXAMPLE_GEOMETRY, example_path, example_shape
from trackdyn.track.formats import TrackFormat
from trackdyn.track.measured import at_sleepers, sleeper_positions

GEOMETRY = str(example_path(EXAMPLE_GEOMETRY))  # 0 to 1000.2 m


def write(path, distance, left, right=None):
    """A measured-stiffness file [kN/mm] of both rails (the right as the left unless given)."""
    right = left if right is None else right
    frame = pd.concat(
        pd.DataFrame({"distance_m": distance, "rail": rail, "stiffness_kN_per_mm": k})
        for rail, k in (("left", left), ("right", right))
    )
    frame.to_csv(path, index=False)
    return str(path)


def measured(path, **keys):
    return load_track(GEOMETRY, path, TrackFormat(supports_kind="measured", **keys))


def secant(curves, load):
    """Each curve's secant stiffness at ``load`` [N/m]."""
    return load / curves.deflection_at(np.full((len(curves), 1), load))[:, 0]


def test_sleepers_along_the_geometry_at_the_stated_spacing():
    # half a spacing in from the start, then every spacing up to the end: 1000.2 m / 0.6 m
    position = sleeper_positions(0.0, 1000.2, 0.6)
    assert position.size == 1667  # floor(1000.2 / 0.6 - 0.5) + 1
    assert position[0] == pytest.approx(0.3) and position[-1] == pytest.approx(999.9)
    np.testing.assert_allclose(np.diff(position), 0.6, rtol=1e-12)


@pytest.mark.parametrize("shape", ["example", "linear"])
def test_each_sleeper_has_the_measured_secant_stiffness_at_the_measured_load(tmp_path, shape):
    # a stiffness rising linearly 50 -> 150 kN/mm over 0-1000 m, 80 kN/mm on the right:
    # linear interpolation is exact on a line, so each sleeper's secant at 100 kN is it
    d = np.linspace(0.0, 1000.0, 11)
    path = write(tmp_path / "k.csv", d, 50 + 0.1 * d, np.full(d.size, 80.0))
    supports = measured(path, stiffness_load_kN=100, curve_shape=shape).supports
    np.testing.assert_allclose(secant(supports.left, 100e3), (50 + 0.1 * supports.position) * 1e6,
                               rtol=1e-9)  # fmt: skip
    np.testing.assert_allclose(secant(supports.right, 100e3), 80e6, rtol=1e-9)


def test_the_example_shape_is_scaled_in_deflection_only(tmp_path):
    # every made curve is the example's median curve times a factor: deflection ratios to
    # its 100 kN point are the median's, at every load point
    d = np.array([0.0, 400.0, 1000.0])
    supports = measured(write(tmp_path / "k.csv", d, [40.0, 120.0, 60.0]),
                        stiffness_load_kN=100).supports  # fmt: skip
    shape = example_shape()
    n = shape.load.size
    made = supports.left.deflection.reshape(-1, n)
    ratio = made / made[:, [4]]  # the shape's 5th point is at 100 kN
    assert shape.load[4] == 100e3
    np.testing.assert_allclose(ratio, np.broadcast_to(shape.deflection / shape.deflection[4],
                                                      ratio.shape), rtol=1e-12)  # fmt: skip
    # the median curve stiffens with load, as ballast does: secant 28.6 kN/mm at 15 kN,
    # 81 at 250 (from the example file's curves)
    assert (np.diff(shape.load[1:] / shape.deflection[1:]) > 0).all()


def test_nearest_and_linear_between_measurements():
    # two measurements, 10 and 20 kN/mm at 0 and 10 m: the closed forms of both rules, end
    # values held beyond
    d, k = np.array([0.0, 10.0]), np.array([10.0, 20.0])
    x = np.array([-5.0, 2.0, 4.9, 5.1, 7.5, 12.0])
    np.testing.assert_allclose(at_sleepers(d, k, x, "linear"), [10, 12, 14.9, 15.1, 17.5, 20])
    np.testing.assert_array_equal(at_sleepers(d, k, x, "nearest"), [10, 10, 10, 20, 20, 20])


def test_a_run_on_the_measured_stiffness_is_near_the_run_on_its_curves(tmp_path):
    # the built-in example's own secant stiffness at 100 kN at each of its sleepers: the
    # supports made of it differ from the example's only in the shape of each curve (the
    # median's), so the 2-DOF wheel loads agree closely (0.07 % RMS of the dynamic load
    # measured when this was written; held to 1 %)
    example = load_track()
    s = example.supports
    path = write(tmp_path / "k.csv", s.position, secant(s.left, 100e3) / 1e6,
                 secant(s.right, 100e3) / 1e6)  # fmt: skip
    made = measured(path, stiffness_load_kN=100, stiffness_between="nearest")
    np.testing.assert_allclose(made.supports.position, s.position, atol=1e-9)
    vehicle, options = load_vehicle("loaded"), RunOptions(model="2dof", speed_kmh=60)
    ref, run = simulate(vehicle, example, options), simulate(vehicle, made, options)
    dyn_ref = ref.wheel_load - ref.wheel_load.mean("time")
    dyn = run.wheel_load - run.wheel_load.mean("time")
    error = float(np.sqrt(((dyn - dyn_ref) ** 2).mean() / (dyn_ref**2).mean()))
    assert error < 0.01


def test_the_shipped_example_is_the_examples_secant_stiffness(tmp_path):
    # examples/stiffness/stiffness.csv: per metre, the secant stiffness at 100 kN of the
    # built-in example's nearest sleeper (six significant digits)
    from importlib.resources import files

    shipped = pd.read_csv(str(files("trackdyn").joinpath("examples/stiffness/stiffness.csv")))
    s = load_track().supports
    for rail in ("left", "right"):
        rows = shipped[shipped["rail"] == rail]
        near = np.abs(s.position[None, :] - rows["distance_m"].to_numpy()[:, None]).argmin(axis=1)
        k = secant(getattr(s, rail), 100e3)[near] / 1e6
        np.testing.assert_allclose(rows["stiffness_kN_per_mm"], k, rtol=1e-5)
