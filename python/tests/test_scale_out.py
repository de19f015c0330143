"""A parameter grid over programs and machines with a standard pool: the runs release the
GIL, so threads run them side by side, and each gives what it gives alone."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from itertools import product

import pytest

import contourcheck as cc
from conftest import sample

PROGRAMS = ["square.nc", "circle-test.nc"]
GAINS = [0.8, 1.0]  # m/min/mm


def run(job):
    name, kv = job
    machine = {"base": "hvmc", "x": {"position_loop": {"kv_m_per_min_per_mm": kv}}}
    r = cc.check(sample(name), machine)
    return name, kv, r.following_error_um.x.max_cutting, r.contour_error_um.max


def test_a_grid_in_a_thread_pool_gives_what_serial_runs_give():
    jobs = list(product(PROGRAMS, GAINS))
    with ThreadPoolExecutor(max_workers=2) as pool:
        pooled = list(pool.map(run, jobs))
    serial = [run(job) for job in jobs]
    assert pooled == serial
    lag = {(name, kv): fe for name, kv, fe, _ in pooled}
    for name in PROGRAMS:
        # The steady lag is F/Kv: 0.8 against 1.0 m/min/mm lags 1.25 times as far.
        assert lag[(name, 0.8)] / lag[(name, 1.0)] == pytest.approx(1.25, rel=0.01)
