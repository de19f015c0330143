"""check from Python: figures equal to the command line's JSON report, physics of the
circular test, the run's samples, programs and machines given every way."""

from __future__ import annotations

import math

import numpy as np
import pytest

import contourcheck as cc
from conftest import ROOT, read_json, sample


def test_python_figures_equal_the_cli_json(cli, tmp_path):
    out = tmp_path / "r.json"
    cli(["check", sample("circle-test.nc"), "--json", str(out), "--tolerance", "6"])
    r = cc.check(sample("circle-test.nc"), tolerance_um=6)
    assert r.report == read_json(out)
    assert r.contour_error_um.max == read_json(out)["contour_error_um"]["max"]


def test_circle_radius_loss_is_the_lag_of_a_first_order_loop():
    # At Kv = 1 m/min/mm (16.67 1/s) and F1000 (16.67 mm/s) on R100, a first-order position
    # loop draws the circle smaller by v²/(2·R·Kv²) = 5.0 µm: F min ≈ −5 µm on both circles.
    r = cc.check(sample("circle-test.nc"))
    v, kv, radius = 1000 / 60, 1000 / 60, 100.0
    expected_um = v**2 / (2 * radius * kv**2) * 1e3
    for circle in r.circular_test.circles:
        assert circle.radius_mm == pytest.approx(radius)
        assert -circle.f_min_um == pytest.approx(expected_um, rel=0.05)
    # F/Kv: 1000 mm/min over 1 m/min/mm lags 1 mm.
    assert r.following_error_um.x.max_cutting == pytest.approx(1000.0, rel=0.01)


def test_samples_are_the_run_behind_the_figures():
    r = cc.check(sample("circle-test.nc"))
    s = r.samples
    n = len(s["t_s"])
    assert all(len(a) == n for a in s.values())
    assert np.allclose(np.diff(s["t_s"]), r.settings.interpolation_cycle_ms * 1e-3)
    assert np.nanmax(np.abs(s["contour_um"])) == pytest.approx(r.contour_error_um.max, abs=1e-9)
    # On the circles (lines 13 and 16) the command runs on R100 about the origin.
    on_circle = np.isin(s["line"], [13, 16])
    radius = np.hypot(s["x_cmd_mm"][on_circle], s["y_cmd_mm"][on_circle])
    assert np.allclose(radius, 100.0, atol=1e-6)
    # The following error is the command less the position.
    assert np.allclose(s["fe_x_um"], (s["x_cmd_mm"] - s["x_mm"]) * 1e3, atol=1e-6)
    assert r.hotspots[0].line == s["line"][np.nanargmax(np.abs(s["contour_um"]))]


def test_programs_and_machines_are_taken_every_way():
    text = (ROOT / "gcode-samples" / "square.nc").read_text()
    from_path = cc.check(sample("square.nc"), "hvmc")
    from_text = cc.check(text, cc.load_machine(None))
    assert from_text.contour_error_um.max == from_path.contour_error_um.max
    toml = "base = \"hvmc\"\n[x.position_loop]\nkv_m_per_min_per_mm = 0.5\n"
    as_dict = {"base": "hvmc", "x": {"position_loop": {"kv_m_per_min_per_mm": 0.5}}}
    slow_toml = cc.check(text, toml)
    slow_dict = cc.check(text, as_dict)
    assert slow_toml.report == slow_dict.report
    # Half the gain, twice the lag: F1000 over 0.5 m/min/mm is 2 mm.
    assert slow_dict.following_error_um.x.max_cutting == pytest.approx(2000.0, rel=0.01)
    assert slow_dict.machine.name == "hvmc"
    m = cc.load_machine("small-table")
    assert m.name == "small-table" and "small-table" in cc.presets()


def test_a_tolerance_gives_the_verdict():
    r = cc.check(sample("circle-test.nc"), tolerance_um=4.0)
    assert r.within_tolerance is False
    assert cc.check(sample("circle-test.nc"), tolerance_um=6.0).within_tolerance is True


def test_the_gil_is_released_while_a_check_runs():
    import threading

    program = cc.load_program(sample("circle-test.nc"))
    done = threading.Event()
    ticks = 0

    def work():
        cc.check(program)
        done.set()

    thread = threading.Thread(target=work)
    thread.start()
    while not done.is_set():
        ticks += 1
    thread.join()
    # Holding the GIL, the run would leave this loop a few switch intervals at most; with it
    # released the loop turns all the while (hundreds of thousands of times).
    assert ticks > 10_000, ticks


def test_the_html_report_holds_the_json_figures(tmp_path):
    r = cc.check(sample("circle-test.nc"), tolerance_um=6.0, report=tmp_path / "r.html")
    page = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and "<svg" in page
    assert 'data-key="contour_error_um.max" data-value="%r"' % r.contour_error_um.max in page
    assert "PASS" in page
    assert not math.isnan(r.max_contour_error_um)
