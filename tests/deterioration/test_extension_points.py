"""The extension points of the deterioration loop, each shown by an addition made here, in
the test alone (registered for the test only, `monkeypatch`): a settlement law, written
as its cycle terms and registered in `LAWS`, and a maintenance policy, a `Policy`
registered in `POLICIES`. Both run through the loop with nothing else changed (the files
docs/architecture.md names for each: the law's class and its parameter table; the policy's
class and its options)."""

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
import xarray as xr

from trackdyn.deterioration import LAWS, LoopOptions, PowerLaw, Traffic, load_law, predict
from trackdyn.deterioration.hardening import Power
from trackdyn.deterioration.maintenance import POLICIES, MaintenanceOptions, Policy
from trackdyn.deterioration.settlement import SettlementLaw
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

LOADED = Traffic(load_vehicle("loaded"), 60.0, 8065.0, "loaded")  # the example's wagon


@dataclass(frozen=True, kw_only=True)
class LinearLaw(SettlementLaw):
    """``e = c (Q/Q_ref)^α (k2/k_ref)^γ N``: settlement linear in the cycles.

    Parameters
    ----------
    c : float
        Settlement of one cycle at the reference load and stiffness [m].
    """

    c: float
    units: ClassVar[dict[str, str]] = {"c": "m"}
    positive: ClassVar[tuple[str, ...]] = ("c",)

    @property
    def terms(self):
        """One linear term (`Power` with exponent 1)."""
        return (Power(self.c, 1.0),)


LINEAR_FILE = """[linear]
Q_ref = { value = 50, unit = "kN", source = "the shipped power law's" }
load_exponent = { value = 2, unit = "-", source = "the shipped power law's" }
k_ref = { value = 100, unit = "kN/mm", source = "the shipped power law's" }
stiffness_exponent = { value = -1, unit = "-", source = "the shipped power law's" }
c = { value = 1e-8, unit = "m", source = "illustrative: 1 mm per 1e5 reference cycles" }
"""


def options(**kw) -> LoopOptions:
    base = {"run": RunOptions(model="4dof"), "total_mgt": 5.0, "snapshot_every_mgt": 5.0,
            "segment_length_m": 60.0, "start": "tamped"}  # fmt: skip
    return LoopOptions(**{**base, **kw})


@pytest.fixture(scope="module")
def short():
    """120 m of FRA class 5 geometry on varying supports."""
    return synthetic_track(120.0, spectrum="fra5", seed=4)


def test_a_settlement_law_added_in_a_test_runs_through_the_loop(short, tmp_path, monkeypatch):
    """A law is its class (its parameters and its cycle terms) and a `LAWS` entry: its
    parameters then read from a file like any shipped law's, and the loop runs it. Its
    one linear term is the power law's with ``beta = 1``, so the loop gives that power
    law's prediction to the bit: the accumulation, the step sizes and the shares all
    follow from the terms."""
    monkeypatch.setitem(LAWS, "linear", LinearLaw)
    (tmp_path / "linear.toml").write_text(LINEAR_FILE)
    law = load_law("linear", tmp_path / "linear.toml")
    assert law == LinearLaw(Q_ref=50e3, load_exponent=2.0, k_ref=100e6,
                            stiffness_exponent=-1.0, c=1e-8)  # fmt: skip
    same = PowerLaw(Q_ref=50e3, load_exponent=2.0, k_ref=100e6, stiffness_exponent=-1.0,
                    K_s=1e-8, beta=1.0)  # fmt: skip
    ds, power = (predict(short, [LOADED], lw, options()) for lw in (law, same))
    assert ds.attrs["settlement_law"] == "LinearLaw"
    assert float(ds.settlement.isel(mgt=-1).max()) > 0
    keep = {k: v for k, v in power.attrs.items() if not k.startswith(("time_", "settlement_"))}
    for d in (ds, power):
        d.attrs = keep
    xr.testing.assert_identical(ds, power)


class WorstOnly(Policy):
    """Tamp the worst segment alone, once its D1 SD reaches the threshold (no minimum
    interval, no neighbours, no alert limit)."""

    def due(self, m, mgt, sd):
        """See `Policy.due`."""
        worst = np.max(sd, axis=0)
        k = int(np.argmax(worst))
        return np.array([k]) if worst[k] >= m.threshold else np.array([], dtype=int)


def test_a_maintenance_policy_added_in_a_test_runs_through_the_loop(short, monkeypatch):
    """A policy is a `Policy` and a `POLICIES` entry: the ``[maintenance]`` options then
    take its name, and the loop tamps what it says is due, at step ends. Threshold 0.5 mm,
    below the D1 SD both 60 m segments start with (measured 1.1 and 1.6 mm): the shipped
    threshold policy tamps both at the first step end; this one tamps one segment at a
    time (measured: 3 tampings in 5 MGT), the worst one of the state stored at its
    tonnage (the state before tamping), which has reached the threshold."""
    with pytest.raises(ValueError, match="unknown maintenance policy 'worst'"):
        MaintenanceOptions(policy="worst")
    monkeypatch.setitem(POLICIES, "worst", WorstOnly)
    o = options(maintenance=MaintenanceOptions(policy="worst"), threshold_sd_mm=0.5)
    ds = predict(short, [LOADED], load_law("power"), o)
    shipped = predict(short, [LOADED], load_law("power"), o.model_copy(
        update={"maintenance": MaintenanceOptions(policy="threshold")}))  # fmt: skip
    assert shipped.intervention_segment.values.tolist() == [0, 1]
    assert np.unique(shipped.intervention_mgt.values).size == 1
    assert ds.attrs["option_maintenance_policy"] == "worst"
    mgt = ds.intervention_mgt.values
    assert mgt.size > 0 and np.unique(mgt).size == mgt.size  # one segment each time
    for m, segment in zip(mgt, ds.intervention_segment.values, strict=True):
        before = ds.d1_sd.sel(mgt=m).max("rail").values
        assert segment == np.argmax(before) and before[segment] >= 0.5
