"""The identification's values and held-out figures as Python reads them from the report:
each value's state (determined, a measurement, traded with another, loose, or the
template's) and the held-out figures each axis is judged by."""

from __future__ import annotations

import json
import math
from typing import Any, Dict

from contourcheck import Identification


class _Native:
    """Stands in for the native run: only its JSON report is read here."""

    def __init__(self, report: Dict[str, Any]) -> None:
        self._text = json.dumps(report)

    def report_json(self) -> str:
        return self._text


def _value(key: str, value: float, uncertainty: Any, determined: bool, measured: bool,
           traded_with: Any = None, loose: bool = False) -> Dict[str, Any]:
    return {"key": key, "unit": "", "template": 1.0, "value": value, "uncertainty": uncertainty,
            "determined": determined, "measured": measured, "traded_with": traded_with,
            "loose": loose}


def _axis(name: str, values: Any, judged_while_moving: bool, while_moving: Any) -> Dict[str, Any]:
    return {"axis": name, "values": values, "better_than_template": True,
            "held_out_template_um": 2.0, "held_out_identified_um": 1.0,
            "following_error_rms_um": 10.0, "held_out_share": 0.1,
            "judged_while_moving": judged_while_moving, "while_moving": while_moving}


REPORT = {
    "file": "record.csv",
    "template": "small-table",
    "axes": [
        _axis("x", [
            _value("controller.gain", 440.0, 22.0, True, True),
            _value("drive.table_mass_kg", 36.0, 30.0, False, False, loose=True),
        ], True, {"held_out_template_um": 0.28, "held_out_identified_um": 0.13,
                  "following_error_rms_um": 1.1, "held_out_share": 0.12}),
        _axis("y", [
            _value("controller.gain", 170.0, 340.0, False, False, traded_with="drive.table_mass_kg"),
            # The template's: no uncertainty (JSON null).
            _value("controller.pole_1_hz", 199.0, None, False, False),
        ], False, {"held_out_template_um": 9.0, "held_out_identified_um": 8.0,
                   "following_error_rms_um": 9.5, "held_out_share": 0.84}),
    ],
}


def test_each_value_says_how_the_record_holds_it():
    values = Identification(_Native(REPORT)).values()
    gain = values["x"]["controller.gain"]
    assert gain["determined"] and gain["measured"] and gain["fitted"]
    assert gain["traded_with"] is None and not gain["loose"]
    mass = values["x"]["drive.table_mass_kg"]
    assert mass["loose"] and mass["fitted"] and not mass["determined"] and not mass["measured"]
    traded = values["y"]["controller.gain"]
    assert traded["traded_with"] == "drive.table_mass_kg"
    assert traded["fitted"] and not traded["determined"] and traded["uncertainty"] == 340.0
    kept = values["y"]["controller.pole_1_hz"]
    assert not kept["fitted"] and math.isnan(kept["uncertainty"]) and kept["value"] == 199.0


def test_each_axis_is_judged_on_its_own_held_out_figures():
    held = Identification(_Native(REPORT)).held_out()
    # X is judged while moving: those figures, not the whole record's.
    assert held["x"] == {"template_um": 0.28, "identified_um": 0.13, "following_error_um": 1.1,
                         "share": 0.12, "while_moving": True, "better_than_template": True}
    # Y is not (its while-moving figures are beside, not the ones it is judged by).
    assert held["y"] == {"template_um": 2.0, "identified_um": 1.0, "following_error_um": 10.0,
                         "share": 0.1, "while_moving": False, "better_than_template": True}
