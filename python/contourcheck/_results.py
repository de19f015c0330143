"""Result objects: the JSON report's figures as attributes, the run's samples as arrays."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterator, List, Mapping, Optional, Union

import numpy as np

PathLike = Union[str, "os.PathLike[str]"]


def _wrap(value: Any) -> Any:
    if isinstance(value, dict):
        return Figures(value)
    if isinstance(value, list):
        return [_wrap(v) for v in value]
    return value


class Figures(Mapping[str, Any]):
    """A JSON object of a report, read by attribute (``r.contour_error_um.max``) or by key
    (``r["contour_error_um"]["max"]``); nested objects are Figures too, ``null`` is None.
    """

    __slots__ = ("_data",)

    def __init__(self, data: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_data", dict(data))

    def __getattr__(self, name: str) -> Any:
        try:
            return _wrap(self._data[name])
        except KeyError:
            raise AttributeError(
                f"no figure '{name}' (there are: {', '.join(self._data)})"
            ) from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("report figures are read-only")

    def __getitem__(self, key: str) -> Any:
        return _wrap(self._data[key])

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __dir__(self) -> List[str]:
        return list(self._data)

    def __repr__(self) -> str:
        return f"Figures({self._data!r})"

    def to_dict(self) -> Dict[str, Any]:
        """The plain JSON object."""
        return json.loads(json.dumps(self._data))


def write_whole(path: PathLike, text: str) -> None:
    """Writes `text` to `path` whole or not at all: staged beside it, then renamed (a symbolic
    link is followed and kept)."""
    target = Path(os.path.realpath(path))
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


class _Result:
    """A run's JSON report, its top-level figures as attributes."""

    _schema = ""

    def __init__(self, native: Any) -> None:
        self._native = native
        self.report: Dict[str, Any] = json.loads(native.report_json())
        """The JSON report, as the command line's ``--json`` writes it."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        report = self.__dict__.get("report", {})
        if name in report:
            return _wrap(report[name])
        raise AttributeError(f"{type(self).__name__} has no '{name}'")

    def __dir__(self) -> List[str]:
        return sorted(set(super().__dir__()) | set(self.report))

    def json(self) -> str:
        """The JSON report as text."""
        return json.dumps(self.report, indent=2)

    def html(self) -> str:
        """The one-page HTML report (self-contained, printable on A4)."""
        return str(self._native.html())

    def write_report(self, path: PathLike) -> None:
        """Writes the HTML report to `path`, whole or not at all."""
        write_whole(path, self.html())


class CheckResult(_Result):
    """A checked program: the report's figures as attributes (``contour_error_um``,
    ``following_error_um``, ``positioning_error_um``, ``hotspots``, ``circular_test``,
    ``cycle_time_s``, ``within_tolerance``, … — see ``docs/report-schema.md``) and the run's
    samples as numpy arrays (:attr:`samples`)."""

    def __init__(self, native: Any) -> None:
        super().__init__(native)
        self._samples: Optional[Dict[str, np.ndarray]] = None

    @property
    def samples(self) -> Dict[str, np.ndarray]:
        """Every interpolation cycle of the run (with the settling tail): ``t_s``, ``line``
        (the program's line being executed), ``x_cmd_mm``, ``y_cmd_mm`` (commanded),
        ``x_mm``, ``y_mm`` (simulated), ``fe_x_um``, ``fe_y_um`` (following error, command −
        actual), ``contour_um`` (NaN where there is no contour: rapids, Z alone, dwells)."""
        if self._samples is None:
            self._samples = dict(self._native.samples())
        return self._samples

    @property
    def max_contour_error_um(self) -> float:
        """The largest contour error while cutting (µm)."""
        return float(self.report["contour_error_um"]["max"])

    def __repr__(self) -> str:
        r = self.report
        return (
            f"<CheckResult {r['program']['file']} on {r['machine']['name']}: "
            f"contour max {r['contour_error_um']['max']:.2f} µm, "
            f"RMS {r['contour_error_um']['rms']:.2f} µm>"
        )


class Diagnosis(_Result):
    """A diagnosis: the report's figures as attributes (``causes``, ``verdict``,
    ``residual``, ``noise_floor_um``, ``circular_test``, … — see ``docs/report-schema.md``)
    and the extended machine (:attr:`machine_toml`)."""

    @property
    def machine_toml(self) -> str:
        """The extended machine as a machine file (what ``--write-machine`` writes)."""
        return str(self._native.machine_toml())

    def found(self) -> List[Dict[str, Any]]:
        """The named causes, one dict each: ``id``, ``axis`` and per fitted value ``key``,
        ``value``, ``uncertainty`` and ``unit``."""
        return [
            {"id": c["id"], "axis": c["axis"], "params": c["params"]}
            for c in self.report["causes"]
        ]

    def __repr__(self) -> str:
        return f"<Diagnosis: {self.report['verdict']}>"


class Identification(_Result):
    """An identified machine: the report's figures as attributes (``axes``, ``noise_um``,
    ``interpolator`` — see ``docs/report-schema.md``) and the machine file
    (:attr:`machine_toml`)."""

    def __init__(self, native: Any) -> None:
        super().__init__(native)

    @property
    def machine_toml(self) -> str:
        """The identified machine as a machine file (what ``identify --out`` writes)."""
        return str(self._native.machine_toml())

    def values(self) -> Dict[str, Dict[str, Dict[str, Any]]]:
        """Per axis (``"x"``, ``"y"``, ``"z"``) and key: ``template``, ``value``,
        ``uncertainty`` (NaN where the template's value is written, not fitted), ``unit``,
        ``determined`` (fitted, the record determining it alone), ``measured`` (and read as
        the machine's own value, not a model's), ``traded_with`` (where the record does not
        determine it alone yet it is written: the key it trades with most; else None),
        ``loose`` (written though the record leaves it loose: the fit's halves predict each
        other while moving to more than twice the noise) and ``fitted`` (the value written
        is fitted to the record — determined, traded or loose — rather than the
        template's)."""
        out: Dict[str, Dict[str, Dict[str, Any]]] = {}
        for a in self.report["axes"]:
            values: Dict[str, Dict[str, Any]] = {}
            for v in a["values"]:
                row = {
                    k: (float("nan") if k == "uncertainty" and v[k] is None else v[k])
                    for k in ("template", "value", "uncertainty", "unit", "determined", "measured")
                }
                row["traded_with"] = v["traded_with"]
                row["loose"] = v["loose"]
                row["fitted"] = v["fitted"]
                values[v["key"]] = row
            out[a["axis"]] = values
        return out

    def held_out(self) -> Dict[str, Dict[str, Any]]:
        """Per axis, the held-out figures the axis is judged by (µm, and the fit's share of
        the following error): ``template_um``, ``identified_um`` (None where the fit has no
        held-out figure: neither half's fit left the whole fit's point), ``following_error_um``,
        ``share`` — the whole record's, or those on the samples while the axis moves where it
        is judged there (``while_moving`` True: its fit reached the noise but its halves'
        fits disagree at standstill, where it hunts) — ``better_than_template``, and
        ``too_little`` (why the record holds too little of the axis to fit or judge it, its
        figures then not to be read; None where it was identified); as the report's
        ``judged_held_out`` states them."""
        out: Dict[str, Dict[str, Any]] = {}
        for a in self.report["axes"]:
            row = dict(a["judged_held_out"])
            row["better_than_template"] = a["better_than_template"]
            row["too_little"] = a.get("too_little")
            out[a["axis"]] = row
        return out

    def __repr__(self) -> str:
        return f"<Identification of {self.report['file']} from {self.report['template']}>"


class SweepResult:
    """A sweep: every setting, ranked (healthy settings by their largest contour error,
    then those flagged for their stability margins or loop damping, then the unstable and
    invalid)."""

    def __init__(self, text: str) -> None:
        self.report: Dict[str, Any] = json.loads(text)
        """The JSON ``sweep --json`` writes."""
        self.dimensions: List[str] = [d["name"] for d in self.report["dimensions"]]
        """The swept keys, in the order of each point's values."""

    @property
    def points(self) -> List[Figures]:
        """Each setting: ``values`` (one per dimension) and ``result`` (``status`` ``ok``,
        ``unstable`` or ``invalid``; for ``ok`` the ``metrics``)."""
        return [Figures(p) for p in self.report["points"]]

    def rows(self) -> List[Dict[str, Any]]:
        """One flat dict per setting, ranked: the swept values by name, ``status``, and for
        simulated settings ``max_contour_um``, ``rms_contour_um``, ``overshoot_um``,
        ``ripple_um``, ``loop_damping`` (the least damping of the closed loops' own modes),
        ``dominated_by`` and ``flagged`` (the thresholds it falls short of; empty when
        healthy)."""
        out = []
        for p in self.report["points"]:
            row: Dict[str, Any] = dict(zip(self.dimensions, p["values"]))
            result = p["result"]
            row["status"] = result["status"]
            if result["status"] == "ok":
                row.update(
                    {k: v for k, v in result["metrics"].items() if k != "max_following_um"}
                )
                row["loop_damping"] = result["health"]["loop_damping"]
                row["dominated_by"] = result["dominant"]["kind"]
                row["flagged"] = [f["kind"] for f in result["flags"]]
            out.append(row)
        return out

    def best(self) -> Optional[Dict[str, Any]]:
        """The setting to use: the first row that was simulated and meets every threshold
        (nothing ``flagged``), or ``None`` where no setting does."""
        return next((r for r in self.rows() if r["status"] == "ok" and not r["flagged"]), None)

    def __len__(self) -> int:
        return len(self.report["points"])
