"""The one failure type: statuses kept through pickling (Dask) and turned back into the
exception they stand for."""

import pickle

import pytest

from trackdyn.errors import (
    Failure,
    Status,
    TrackdynError,
    TrackdynInputError,
    TrackdynNumericalError,
)


@pytest.mark.parametrize(
    "exc, kind",
    [
        (TrackdynInputError("bad row 3"), TrackdynInputError),
        (TrackdynNumericalError("Newton", Status.NEWTON_DIVERGED), TrackdynNumericalError),
        (TrackdynNumericalError("away", Status.SETTLEMENT_RAN_AWAY), TrackdynNumericalError),
        (TrackdynError("lost", Status.WORKER_LOST), TrackdynError),
    ],
)
def test_status_survives_pickling_and_comes_back_as_its_exception(exc, kind):
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is kind and back.status is exc.status and str(back) == str(exc)
    failure = pickle.loads(pickle.dumps(Failure.of(exc)))
    assert failure == Failure(exc.status, str(exc))
    again = failure.named("section a").error()
    assert type(again) is kind and again.status is exc.status
    assert str(again) == f"section a: {exc}"


def test_an_input_error_is_a_value_error_and_a_bug_is_failed_with_its_type():
    assert isinstance(TrackdynInputError("x"), ValueError)
    try:
        raise KeyError("k")
    except KeyError as exc:
        failure = Failure.of(exc)
    assert failure.status is Status.FAILED
    assert failure.message.startswith("KeyError: 'k' (") and "test_errors.py" in failure.message
