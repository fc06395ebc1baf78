"""The lanes' tuple operations: each the scalar expression in every lane, operands in
alphabetical order, upper-case names the same in every lane."""

import numba
import numpy as np
import pytest
from numba import njit

from trackdyn.lanewise import LANES, lanewise, load, store, total, vectorised

_fma = lanewise("c + a * b")
_state = lanewise("(c * v > u) + 2 * ((c * v < -d) & (c * v <= u))")
_bit = lanewise("m + (K if s == 0 else 0)")


@njit
def _apply(a, b, c, out):
    for r in range(a.size // LANES):
        store(out, r, _fma(load(a, r), load(b, r), load(c, r)))
    return total(load(out, 0))


def test_each_lane_gets_the_scalar_expression():
    rng = np.random.default_rng(1)
    a, b, c = (rng.normal(size=3 * LANES) for _ in range(3))
    out = np.empty(3 * LANES)
    first = _apply(a, b, c, out)
    # numpy's c + a * b rounds the product, the compiled one may fuse it (one FMA): they
    # differ by that one rounding and the sum's, each at most eps/2 of its magnitude
    bound = np.finfo(float).eps * (np.abs(a * b) + np.abs(c))
    assert np.all(np.abs(out - (c + a * b)) <= bound)
    # `total` adds the lanes in order, numpy pairwise: 7 additions' rounding, 8 eps bounds it
    assert abs(first - out[:LANES].sum()) <= 8 * np.finfo(float).eps * np.abs(out[:LANES]).sum()


@njit
def _states(c, d, u, v):
    return _state(c, d, u, v)


@njit
def _bits(m, s):
    return _bit(m, s, 4)


def test_conditions_as_arithmetic_select_as_the_nested_expression():
    # written as arithmetic to vectorise: 1 above the slip force up, 2 below minus the
    # slip force down, 0 between (the per-run loop's nested `if`), up first where both hold
    c = (1.0,) * LANES
    v = (3.0, -3.0, 0.5, 2.0, -2.0, 0.0, 5.0, -5.0)
    u = (1.0, 1.0, 1.0, 2.0, 1.0, 1.0, -1.0, 1.0)
    d = (1.0, 1.0, 1.0, 1.0, 2.0, 1.0, -6.0, 1.0)
    nested = tuple(1 if ci * vi > ui else (2 if ci * vi < -di else 0)
                   for ci, vi, ui, di in zip(c, v, u, d, strict=True))  # fmt: skip
    assert _states(c, d, u, v) == nested == (1, 2, 0, 0, 0, 0, 1, 2)
    assert _bits((1,) * LANES, (0, 1, 2, 0, 1, 2, 0, 1)) == (5, 1, 1, 5, 1, 1, 5, 1)


def test_vectorised_restores_numbas_setting():
    before = numba.config.SLP_VECTORIZE
    with pytest.raises(RuntimeError), vectorised():
        assert numba.config.SLP_VECTORIZE == 1
        raise RuntimeError
    assert numba.config.SLP_VECTORIZE == before


_twice_plus = lanewise("b + 2.0 * a")


def _scaled_sum(a, out, zero):
    """Each row of ``out`` twice the row of ``a`` plus the row before; the lanes' total of
    row 0."""
    acc = zero
    for r in range(a.size // len(zero)):
        acc = _twice_plus(load(a, r), acc)
        store(out, r, acc)
    return total(load(out, 0))


_written = njit(inline="never")(_scaled_sum)


def test_widened_makes_a_function_for_one_lane():
    # the same function, written once on tuples of LANES values and made for one value:
    # each lane's column of the group's result is what the one-lane copy gives on that
    # lane's column alone (the same operations in the same order: equal to the bit)
    from trackdyn.lanewise import widened

    one = widened({**globals(), "_written": _written}, ("_written",), 1)["_written"]
    rng = np.random.default_rng(3)
    rows = 5
    a = rng.normal(size=rows * LANES)
    out = np.empty(rows * LANES)
    _written(a, out, (0.0,) * LANES)
    for b in range(LANES):
        alone = np.empty(rows)
        first = one(np.ascontiguousarray(a.reshape(rows, LANES)[:, b]), alone, (0.0,))
        np.testing.assert_array_equal(alone, out.reshape(rows, LANES)[:, b])
        assert first == alone[0]
