"""Operations on a group of the vector lanes, as tuples of `LANES` values.

`trackdyn.solver.lanes.advance_lanes` holds each quantity of a step (a displacement, a
contact force, a wedge's state) of its `LANES` runs as one tuple, and
`trackdyn.beam.railseat` each entry of the banded solve of its `LANES` wheel positions:
read with `load` from a flat array, one row of `LANES` values after the other, combined by
functions made with `lanewise`, written back with `store`. A tuple's values are values,
not memory: each operation reads all its operands before anything is written, so LLVM's
SLP vectoriser packs the lanes into vector registers. Written as loops over the lanes on
arrays instead, a lane's loads cannot be moved past the previous lane's stores (numba
gives LLVM no way to know that two arrays do not overlap), and the step stays scalar.
Conditions are written as arithmetic where a nested ``if``-expression would compile to
branches, lane by lane.

The SLP vectoriser is off in numba by default (``NUMBA_SLP_VECTORIZE``); `vectorised`
turns it on while a loop is compiled.
"""

from __future__ import annotations

import functools
import re
import types
from contextlib import contextmanager

import numba
import numpy as np
from numba import njit

LANES = 8
"""Runs of one model (or wheel positions on the rail beam) in a group of the vector lanes:
a compile-time constant, so that an operation on a group is a fixed number of
instructions (8 doubles: two of the 256-bit registers LLVM prefers on AVX-512 machines).
A group of runs costs as much with fewer lanes filled, so a few runs left over go one by
one (`trackdyn.solver.lanes.MIN_LANE_RUNS`); with 4 lanes, 8 runs cost more (see the
benchmarks)."""

FASTMATH = {"nnan", "ninf", "nsz", "contract", "afn"}
"""LLVM's fast-math flags of the loops: all but reassociation, so that a run's sums are
done in the same order alone and in the lanes (the same results, to the bit)."""

_OPERAND = re.compile(r"\b([a-z])\b")
_SCALAR = re.compile(r"\b([A-Z])\b")


def _compiled(source: str):
    """The numba function (inlined into its callers) defined by ``source``."""
    namespace: dict = {"np": np}
    exec(source, namespace)  # noqa: S102 - the source is built in this module only
    (function,) = (v for k, v in namespace.items() if k not in ("np", "__builtins__"))
    return njit(inline="always", fastmath=FASTMATH, error_model="numpy")(function)


@functools.cache
def lanewise(expression: str, width: int = LANES):
    """A numba function applying the scalar ``expression`` in every lane.

    Its one-letter lower-case names are the operands, tuples of ``width`` values, passed
    in alphabetical order; upper-case names are scalars, the same in every lane, passed
    after them (``lanewise("c + a * b")(a, b, c)``; ``lanewise("m + (K if s == 0 else
    0)")(m, s, K)``). The result is a tuple of ``width`` values. The function keeps its
    expression (``lane_expression``), so that `widened` can make it at another width.
    """
    lanes = sorted(set(_OPERAND.findall(expression)))
    scalars = sorted(set(_SCALAR.findall(expression)))
    terms = ", ".join(_OPERAND.sub(rf"\1[{b}]", expression) for b in range(width))
    function = _compiled(f"def lanewise({', '.join(lanes + scalars)}):\n    return ({terms},)\n")
    function.lane_expression = expression
    return function


@functools.cache
def rows(width: int = LANES) -> dict:
    """``load``, ``store`` and ``total`` for tuples of ``width`` values (`load`, `store`,
    `total` are those of `LANES`)."""
    values = ", ".join(f"a[k + np.uint64({b})]" for b in range(width))
    stores = "".join(f"    a[k + np.uint64({b})] = t[{b}]\n" for b in range(width))
    row = f"    k = np.uint64(r) * np.uint64({width})\n"
    return {
        "load": _compiled(f"def load(a, r):\n{row}    return ({values},)\n"),
        "store": _compiled(f"def store(a, r, t):\n{row}{stores}"),
        "total": _compiled(
            f"def total(t):\n    return {' + '.join(f't[{b}]' for b in range(width))}\n"
        ),
    }


load = rows()["load"]
"""``load(a, r)``: row ``r`` of the flat array ``a`` of rows of `LANES` values, as a
tuple. ``r`` is not negative: taken unsigned, it is used without numba's check for
indices from the end, and a flat array's rows without a multiplication by its width."""

store = rows()["store"]
"""``store(a, r, t)``: the tuple ``t`` into row ``r`` of the flat array ``a`` (`load`)."""

total = rows()["total"]
"""``total(t)``: the sum of the lanes' values of the tuple ``t``."""


def widened(namespace: dict, names: tuple[str, ...], width: int) -> dict:
    """The numba functions ``names`` of a module (its globals ``namespace``), written on
    the tuples of `LANES` values, made for tuples of ``width`` values.

    Each is a copy of its Python function whose globals have every tuple operation
    (`lanewise`, `load`, `store`, `total`) at ``width`` and each other function of
    ``names`` as its copy; compiled with the same numba options (inlined where the original
    is), so that a function written once serves a group of lanes and a run alone (width 1).
    """
    space = dict(namespace)
    for key, value in namespace.items():
        if hasattr(value, "lane_expression"):
            space[key] = lanewise(value.lane_expression, width)
        elif any(value is f for f in (load, store, total)):
            space[key] = rows(width)[value.__name__]
    made = {}
    for name in names:
        original = namespace[name]
        func = original.py_func
        copy = types.FunctionType(func.__code__, space, func.__name__, func.__defaults__)
        options = {k: v for k, v in original.targetoptions.items() if k != "nopython"}
        made[name] = space[name] = njit(**options)(copy)
    return made


@contextmanager
def vectorised():
    """numba compiles with LLVM's SLP vectoriser inside this context (the loops over the
    lanes' tuples are compiled at their first call, or loaded from numba's cache).

    numba's setting is the process's: a function another thread compiles meanwhile gets
    the SLP vectoriser too. `trackdyn.solver.central.solve` enters it only around the
    lanes' loop, after the first block's track input was sampled (which compiles the
    sampling).
    """
    before = numba.config.SLP_VECTORIZE
    numba.config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        numba.config.SLP_VECTORIZE = before
