"""Dask's malloc setting undone in a worker's task (`trackdyn.parallel.keep_freed_memory`).

A process started as Dask's nanny starts a worker (``MALLOC_TRIM_THRESHOLD_=65536``)
allocates, fills and frees a 1 MiB array many times. Under the setting glibc maps each one
afresh, so each fill page-faults its 256 pages of 4 KiB again; once the task has set the
thresholds, the first array's pages fault once and every later round reuses them.
"""

import json
import os
import platform
import subprocess
import sys

import pytest

pytestmark = [
    pytest.mark.slow,  # a subprocess
    pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="a glibc malloc setting"),
]

PAGES = 256  # 1 MiB in 4 KiB pages
ROUNDS = 1000

SCRIPT = f"""
import json, resource
import numpy as np
from trackdyn.parallel import keep_freed_memory

def faults():
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range({ROUNDS}):
        np.ones({PAGES} * 4096, dtype=np.uint8)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

under_dask = faults()
kept = keep_freed_memory()
print(json.dumps({{"under_dask": under_dask, "kept": kept, "after": faults()}}))
"""


def test_a_task_reuses_freed_arrays_under_dasks_malloc_setting():
    env = {**os.environ, "MALLOC_TRIM_THRESHOLD_": "65536"}  # distributed's nanny default
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                         text=True, check=True)  # fmt: skip
    got = json.loads(out.stdout)
    assert got["kept"] is True
    # under the setting: every round maps the array afresh and faults each of its pages
    assert got["under_dask"] >= 0.9 * PAGES * ROUNDS
    # with the thresholds set: the first array's pages once (and a few of the interpreter's),
    # however many rounds
    assert got["after"] <= 2 * PAGES
