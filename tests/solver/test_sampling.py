"""The track input sampled ahead in a thread, or in turn with the compiled loop.

`central.solve` samples the next block's track input in a thread while the loop advances
this one when numba may use more than one thread, and in turn with it when it may use one
(a Dask worker's task). The blocks are the same and a run's results depend only on its
own input, so the two must agree to the bit, also when a run stops part way (its later
blocks are then not sampled in turn, and sampled but not used ahead).
"""

import numpy as np
import pytest

from trackdyn.errors import Failure
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch
from trackdyn.solver import central
from trackdyn.vehicle.parameters import load_vehicle

V = load_vehicle("loaded")
STICKY = load_vehicle("loaded", C_slope=1.0)  # its wedges stick: one Newton pass is enough


@pytest.fixture()
def small_blocks(monkeypatch):
    monkeypatch.setattr(central, "CHUNK_STEPS", 700)  # many blocks per run


def solved(lin, threads, monkeypatch):
    monkeypatch.setattr(central.numba, "get_num_threads", lambda: threads)
    # a group in the lanes and a run alone; the loaded wagon's wedges (runs 1 and 8) need a
    # second Newton pass and fail part way (`test_lanes`)
    vehicles = [V if i in (1, central.LANES) else STICKY for i in range(central.LANES + 1)]
    options = [RunOptions(speed_kmh=50.0 + 5.0 * i, store_every=2)
               for i in range(central.LANES + 1)]  # fmt: skip
    return run_batch(vehicles, lin, options, newton_max_iter=1)


def test_sampling_in_turn_gives_what_sampling_ahead_gives(lin, small_blocks, monkeypatch):
    ahead, in_turn = solved(lin, 2, monkeypatch), solved(lin, 1, monkeypatch)
    failed = [isinstance(r, Failure) for r in ahead]
    assert failed[1] and failed[central.LANES] and not all(failed)
    for a, b in zip(ahead, in_turn, strict=True):
        if isinstance(a, Failure):
            assert str(a) == str(b)
            continue
        for name, values in a.out.items():
            np.testing.assert_array_equal(b.out[name], values, err_msg=name)
