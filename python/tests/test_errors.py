"""Errors become exceptions that name the place: file, line and column of a program, key
(and line) of a machine file, row of a trace file, sample of arrays."""

from __future__ import annotations

import numpy as np
import pytest

import contourcheck as cc
from conftest import sample


def test_a_bad_program_names_file_line_and_column():
    with pytest.raises(cc.ProgramError) as e:
        cc.load_program("G21 G90\nG1 X10 F100\nG1 X20 G5\n", name="part.nc")
    assert (e.value.file, e.value.line, e.value.column) == ("part.nc", 3, 8)
    assert e.value.problems[0]["line"] == 3


def test_a_program_outside_the_travel_names_its_line():
    with pytest.raises(cc.ProgramError) as e:
        cc.check("G21 G90\nG0 X0 Y0\nG1 X99999 F1000\nM2\n")
    assert e.value.line == 3


def test_a_machine_file_error_names_the_key_and_its_place(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text('base = "hvmc"\n[x.drive]\nbacklash_um = -3\n')
    with pytest.raises(cc.MachineError) as e:
        cc.load_machine(path)
    assert (e.value.key, e.value.line, e.value.column) == ("x.drive.backlash_um", 3, 1)
    assert e.value.file == str(path)
    with pytest.raises(cc.MachineError) as e:
        cc.load_machine({"base": "hvmc", "x": {"drive": {"baklash_um": 3}}})
    assert e.value.key == "x.drive.baklash_um" and e.value.line is None
    assert "did you mean `backlash_um`" in str(e.value)
    with pytest.raises(cc.MachineError) as e:
        cc.load_machine('base = "hvmc"\n[x.drive\n')
    assert e.value.line == 2


def test_a_trace_error_names_the_row_or_the_sample(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("t_s,x_mm,y_mm\n0,0,0\n0.001,0,0\n0.002,zero,0\n0.003,0,0\n")
    with pytest.raises(cc.TraceError) as e:
        cc.read_trace(path)
    assert (e.value.file, e.value.row) == (str(path), 4)
    t = np.arange(100) * 1e-3
    x = np.zeros(100)
    x[42] = np.nan
    with pytest.raises(cc.TraceError) as e:
        cc.trace_from_arrays(t, x, np.zeros(100))
    assert e.value.sample == 42 and e.value.row is None


def test_unknown_names_are_usage_errors():
    with pytest.raises(cc.UsageError):
        cc.check(sample("square.nc"), profile="bang-bang")
    with pytest.raises(ValueError):
        cc.load_machine("no-such-machine")
    with pytest.raises(cc.InputError) as e:
        cc.load_program("missing.nc")
    assert e.value.file == "missing.nc"
