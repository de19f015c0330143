"""identify from Python: where the record read the positions, as the command line takes it."""

from __future__ import annotations

import pytest

import contourcheck as cc
from conftest import read_json, sample

NOISE_UM = 0.2


def test_a_motor_record_is_compared_at_the_motor(cli, tmp_path):
    # hvmc recorded at its motors, identified from itself: at the motors only the noise is
    # left; read as the table, the screw's wind-up while moving stays — the Coulomb friction
    # c·M·g over the axial stiffness: 0.010 · 6000 kg · 9.81 m/s² / 3.6e8 N/m = 1.6 µm, of
    # which a fit may pass part for lag (half is asked).
    program = sample("identify-moves.nc")
    record = str(tmp_path / "motor.csv")
    cli(["synth", program, "--out", record, "--with-commands", "--rate-hz", "1000",
         "--noise-um", str(NOISE_UM), "--measured-at", "motor"])
    out = tmp_path / "id.json"
    cli(["identify", program, "--measured", record, "--measured-at", "motor",
         "--json", str(out), "--out", str(tmp_path / "id.toml")])
    at_motor = cc.identify(program, record, measured_at="motor")
    as_table = cc.identify(program, record)
    held = lambda r: [a["held_out_identified_um"] for a in r["axes"]]  # noqa: E731
    assert held(at_motor.report) == held(read_json(out))
    wind_up_um = 0.010 * 6000 * 9.81 / 3.6e8 * 1e6
    for motor, table in zip(held(at_motor.report), held(as_table.report)):
        assert motor < 1.5 * NOISE_UM
        assert table > 0.5 * wind_up_um
    with pytest.raises(cc.UsageError, match="measured_at 'scale'"):
        cc.identify(program, record, measured_at="scale")
