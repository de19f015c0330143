"""Traces, diagnose and sweep from Python: arrays in, the command line's figures out."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import contourcheck as cc
from conftest import read_json, sample

BACKLASH_UM = 10.0


@pytest.fixture(scope="module")
def record():
    """A record of the square on a machine with 10 µm of backlash on X, its positions read
    with 0.1 µm of noise, the commands recorded."""
    hidden = cc.check(sample("square.nc"), {"base": "hvmc", "x": {"drive": {"backlash_um": BACKLASH_UM}}})
    s = hidden.samples
    rng = np.random.default_rng(7)
    noisy = lambda a: a + rng.normal(0.0, 1e-4, a.shape)
    return {
        "t_s": s["t_s"],
        "x_mm": noisy(s["x_mm"]),
        "y_mm": noisy(s["y_mm"]),
        "x_cmd_mm": s["x_cmd_mm"],
        "y_cmd_mm": s["y_cmd_mm"],
    }


def write_csv(path, record):
    keys = ["t_s", "x_mm", "y_mm", "x_cmd_mm", "y_cmd_mm"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for row in zip(*(record[k] for k in keys)):
            w.writerow([repr(float(v)) for v in row])


def test_a_trace_reads_back_as_arrays_with_its_column_mapping(tmp_path, record):
    path = tmp_path / "export.csv"
    # A control's export: its own names and units (ms, µm).
    with open(path, "w") as f:
        f.write("Time;X_ActPos;Y_ActPos\n")
        for t, x, y in zip(record["t_s"][:500], record["x_mm"][:500], record["y_mm"][:500]):
            fields = [repr(float(v) * 1e3).replace(".", ",") for v in (t, x, y)]
            f.write(";".join(fields) + "\n")
    trace = cc.read_trace(path, columns="t=Time[ms],x=X_ActPos[um],y=Y_ActPos[um]")
    a = trace.arrays()
    assert len(trace) == 500 and trace.dt_s == pytest.approx(2e-3)
    assert np.allclose(a["x_mm"], record["x_mm"][:500], atol=1e-9)
    assert "x_cmd_mm" not in a
    columns = trace.columns()
    assert columns["x"]["header"] == "X_ActPos" and columns["x"]["column"] == 1
    assert any("decimal comma" in line for line in trace.describe())


def test_diagnose_finds_the_hidden_backlash_as_the_cli_does(cli, tmp_path, record):
    found = cc.diagnose(sample("square.nc"), record)
    causes = found.found()
    assert [(c["id"], c["axis"]) for c in causes] == [("backlash", "x")]
    value = causes[0]["params"][0]
    assert abs(value["value"] - BACKLASH_UM) < max(3 * value["uncertainty"], 0.2)
    assert "backlash_um" in found.machine_toml
    # The same record through the command line.
    path = tmp_path / "record.csv"
    write_csv(path, record)
    out = tmp_path / "d.json"
    cli(["diagnose", sample("square.nc"), "--measured", str(path), "--json", str(out)])
    theirs = read_json(out)
    ours = found.report
    assert ours["causes"] == theirs["causes"]
    assert ours["residual"] == theirs["residual"]
    assert ours["verdict"] == theirs["verdict"]
    page = found.html()
    assert 'data-key="causes[0].params[0].value"' in page


def test_sweep_ranks_gains_as_the_cli_does(cli, tmp_path):
    grid = {"x.kv_m_per_min_per_mm": [0.8, 1.0, 1.2], "y.kv_m_per_min_per_mm": [1.0]}
    ours = cc.sweep(sample("square.nc"), grid)
    out = tmp_path / "s.json"
    cli(["sweep", sample("square.nc"), "--axis", "x", "--kv", "0.8:1.2:0.2", "--axis", "y",
         "--kv", "1.0:1.0:0.1", "--json", str(out)])
    theirs = read_json(out)
    assert [p["result"] for p in ours.report["points"]] == [p["result"] for p in theirs["points"]]
    assert [p["values"] for p in ours.report["points"]] == [p["values"] for p in theirs["points"]]
    # X's steady lag is F/Kv: 1000 mm/min over 0.8, 1.0 and 1.2 m/min/mm.
    lag = {p["values"][0]: p["result"]["metrics"]["max_following_um"][0] for p in ours.report["points"]}
    for kv, fe in lag.items():
        assert fe == pytest.approx(1000.0 / kv, rel=0.01)
    # Y's Kv of 1 leaves its position loop 5 dB from the edge of stability (the table's
    # axial mode): short of 6 dB in every row, no setting is the one to use; at 3 dB, X at
    # 1.0 is (1.2 takes the table mode's damping below 0.05).
    assert ours.best() is None
    lax = cc.sweep(sample("square.nc"), grid, min_gain_margin=3.0)
    assert lax.best()["x.kv_m_per_min_per_mm"] == 1.0


def test_identify_finds_the_gain_the_record_ran_with_as_the_cli_does(cli, tmp_path):
    # The hvmc cascade with X's position gain at 1.2 instead of the template's 1.0 m/min/mm,
    # recorded with its commands and 0.05 µm of noise.
    truth = {"base": "hvmc", "x": {"position_loop": {"kv_m_per_min_per_mm": 1.2}}}
    s = cc.check(sample("small-circle.nc"), truth).samples
    rng = np.random.default_rng(3)
    noisy = lambda a: a + rng.normal(0.0, 5e-5, a.shape)
    record = {"t_s": s["t_s"], "x_mm": noisy(s["x_mm"]), "y_mm": noisy(s["y_mm"]),
              "x_cmd_mm": s["x_cmd_mm"], "y_cmd_mm": s["y_cmd_mm"]}
    found = cc.identify(sample("small-circle.nc"), record, "hvmc")
    kv = found.values()["x"]["position_loop.kv_m_per_min_per_mm"]
    assert kv["determined"] and abs(kv["value"] - 1.2) < 3 * kv["uncertainty"] < 0.05
    fitted = cc.check(sample("small-circle.nc"), found.machine_toml)
    assert fitted.following_error_um.x.max_cutting == pytest.approx(
        cc.check(sample("small-circle.nc"), truth).following_error_um.x.max_cutting, rel=0.01
    )
    path = tmp_path / "record.csv"
    write_csv(path, record)
    out, json_out = tmp_path / "mine.toml", tmp_path / "i.json"
    cli(["identify", sample("small-circle.nc"), "--measured", str(path), "--template", "hvmc",
         "--out", str(out), "--json", str(json_out)])
    theirs = read_json(json_out)
    assert found.report["axes"] == theirs["axes"]
    # Every value's state as values() reads it, from the fields the report writes.
    for axis in theirs["axes"]:
        for v in axis["values"]:
            mine = found.values()[axis["axis"]][v["key"]]
            assert (mine["traded_with"], mine["loose"]) == (v["traded_with"], v["loose"])
    # The same file but for the record's name.
    assert found.machine_toml.replace("<arrays>", str(path)) == out.read_text()
