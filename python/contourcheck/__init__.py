"""contourcheck: the contour error of a CNC machine predicted from its part program, and its
servo-feed model calibrated from measured traces.

The Python face of the contourcheck library: the same engine and the same figures as the
command line's JSON reports, with numpy arrays in and out, for notebooks and scripts.
Every run releases the GIL, so threads (``concurrent.futures``) run checks in parallel.

>>> import contourcheck as cc
>>> r = cc.check("gcode-samples/circle-test.nc")          # doctest: +SKIP
>>> r.contour_error_um.max, r.samples["contour_um"]       # doctest: +SKIP

Programs are given as a :class:`Program`, a path, or G-code text (a ``str`` with a line
break); machines as a :class:`Machine`, a preset's name (``"hvmc"``, ``"small-table"``), a
path, a machine file's text, or a ``dict`` of its tables; measured traces as a
:class:`Trace`, a path, or a ``dict`` of arrays (``t_s``, ``x_mm``, ``y_mm`` and, where
recorded, ``x_cmd_mm``, ``y_cmd_mm``). See ``docs/python.md``.
"""

from __future__ import annotations

import json
import os
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native
from ._native import Machine, Program, Trace
from ._results import CheckResult, Diagnosis, Figures, Identification, SweepResult, write_whole
from .errors import (
    AnalysisError,
    ContourcheckError,
    InputError,
    MachineError,
    ProgramError,
    ReportError,
    SimulationError,
    TraceError,
    UsageError,
)

__version__: str = _native.__version__

__all__ = [
    "check",
    "sweep",
    "read_trace",
    "trace_from_arrays",
    "diagnose",
    "identify",
    "load_machine",
    "load_program",
    "presets",
    "Machine",
    "Program",
    "Trace",
    "CheckResult",
    "SweepResult",
    "Diagnosis",
    "Identification",
    "Figures",
    "ContourcheckError",
    "ProgramError",
    "MachineError",
    "TraceError",
    "SimulationError",
    "AnalysisError",
    "UsageError",
    "InputError",
    "ReportError",
]

PathLike = Union[str, "os.PathLike[str]"]
ProgramLike = Union[Program, PathLike]
MachineLike = Union[None, Machine, PathLike, Mapping[str, Any]]
TraceLike = Union[Trace, PathLike, Mapping[str, Any]]


def presets() -> list:
    """The embedded machines' names."""
    return list(_native.presets())


def load_machine(spec: MachineLike = None) -> Machine:
    """A machine from what the user has: None (the ``hvmc`` preset), a :class:`Machine`, a
    preset's name, a machine file's text (a ``str`` with a line break or ``=``), a path, or
    a ``dict`` of the file's tables (``{"base": "hvmc", "x": {"drive": {"backlash_um":
    12.0}}}``).

    Raises:
        MachineError: a key the machine has not, a value no machine has (with ``key``,
            ``line``, ``column``), a preset that does not exist.
    """
    if spec is None:
        return Machine.preset("hvmc")
    if isinstance(spec, Machine):
        return spec
    if isinstance(spec, Mapping):
        return Machine.from_json(json.dumps(spec))
    if isinstance(spec, str):
        if "\n" in spec or "=" in spec:
            return Machine.from_toml(spec)
        if spec in presets() and not os.path.exists(spec):
            return Machine.preset(spec)
    if isinstance(spec, (str, os.PathLike)):
        path = os.fspath(spec)
        if not os.path.exists(path):
            raise UsageError(
                f"machine '{path}': no such file, and no embedded preset of that name "
                f"(presets: {', '.join(presets())})",
                file=path,
            )
        return Machine.from_file(path)
    raise UsageError(f"machine: a preset's name, a path, a TOML text or a dict, not {spec!r}")


def load_program(spec: ProgramLike, *, name: Optional[str] = None, dialect: Optional[str] = None) -> Program:
    """A program from a :class:`Program`, a path, or G-code text (a ``str`` with a line
    break; `name` names it in errors). `dialect`: ``"rs274"`` or ``"sinumerik"`` (default:
    told from the file).

    Raises:
        ProgramError: with ``file``, ``line``, ``column`` and every problem in ``problems``.
        InputError: a file that cannot be read.
    """
    if isinstance(spec, Program):
        return spec
    if isinstance(spec, str) and "\n" in spec:
        return Program.from_text(spec, name or "<text>", dialect)
    if isinstance(spec, (str, os.PathLike)):
        return Program.from_file(os.fspath(spec), dialect)
    raise UsageError(f"program: a path or G-code text, not {spec!r}")


def read_trace(
    path: PathLike,
    *,
    columns: Optional[str] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
) -> Trace:
    """Reads a measured trace: CSV and other text tables, MATLAB MAT-files, LinuxCNC
    halscope logs, SINUMERIK Operate traces, TwinCAT Scope exports.

    `columns` maps the file's columns with units (``"t=Time[ms],x=X_ActPos[mm],…"``; None:
    recognised from the header). `work_offset_mm`: the program origin ``(x, y)`` in the
    trace's coordinates, subtracted from every position. ``trace.arrays()`` gives the samples
    as numpy arrays, ``trace.columns()`` how each signal was found.

    Raises:
        TraceError: with ``file`` and ``row``.
    """
    offset = None if work_offset_mm is None else (float(work_offset_mm[0]), float(work_offset_mm[1]))
    return _native.read_trace(os.fspath(path), columns, offset)


def trace_from_arrays(
    t_s: Any,
    x_mm: Any,
    y_mm: Any,
    x_cmd_mm: Any = None,
    y_cmd_mm: Any = None,
    *,
    name: str = "<arrays>",
) -> Trace:
    """A trace from arrays: time (s), measured X and Y (mm), and where recorded the
    commanded X and Y (mm). Checked as a file is (time increasing, no gaps, finite values).

    Raises:
        TraceError: with ``sample``, the index of the offending sample.
    """
    def f64(a: Any) -> Optional[np.ndarray]:
        return None if a is None else np.ascontiguousarray(a, dtype=np.float64)

    return _native.trace_from_arrays(f64(t_s), f64(x_mm), f64(y_mm), f64(x_cmd_mm), f64(y_cmd_mm), name)


def _trace(spec: Optional[TraceLike]) -> Optional[Trace]:
    if spec is None or isinstance(spec, Trace):
        return spec
    if isinstance(spec, Mapping):
        return trace_from_arrays(
            spec["t_s"], spec["x_mm"], spec["y_mm"], spec.get("x_cmd_mm"), spec.get("y_cmd_mm")
        )
    return read_trace(spec)


def _report(result: Any, path: Optional[PathLike]) -> Any:
    if path is not None:
        result.write_report(path)
    return result


def check(
    program: ProgramLike,
    machine: MachineLike = None,
    *,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    blend_tolerance_mm: Optional[float] = None,
    tolerance_um: Optional[float] = None,
    report: Optional[PathLike] = None,
) -> CheckResult:
    """Predicts a program's contour error on a machine (``contourcheck check``).

    Args:
        program: the part program (see :func:`load_program`).
        machine: the machine (see :func:`load_machine`); default the ``hvmc`` preset.
        profile: ``"s-curve"`` (default), ``"trapezoid"`` or ``"ideal"``.
        cycle_ms: the interpolation cycle (default: the machine's).
        blend_tolerance_mm: corner tolerance under G64 without P (default 0.01 mm).
        tolerance_um: the largest contour error allowed: ``within_tolerance`` says.
        report: write the one-page HTML report there.

    Returns:
        A :class:`CheckResult`: the JSON report's figures as attributes, the samples as
        arrays.

    Raises:
        ProgramError, MachineError, SimulationError, UsageError.
    """
    native = _native.check(
        load_program(program), load_machine(machine), profile, cycle_ms, blend_tolerance_mm, tolerance_um
    )
    return _report(CheckResult(native), report)


def sweep(
    program: ProgramLike,
    grid: Mapping[str, Sequence[float]],
    machine: MachineLike = None,
    *,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    min_damping: float = 0.05,
    min_phase_margin: float = 30.0,
    min_gain_margin: float = 6.0,
) -> SweepResult:
    """Compares machine settings on a program (``contourcheck sweep``): every combination
    of `grid`'s values, in parallel, ranked.

    `grid` maps machine keys to values: ``{"x.kv_m_per_min_per_mm": [0.8, 1.0, 1.2],
    "xy.backlash_um": [0, 10]}`` — a key as ``axis.leaf`` or ``axis.section.leaf``,
    ``xy.`` for both axes alike (docs/machine-keys.md lists the keys). A setting with a
    loop below `min_phase_margin` (degrees) or `min_gain_margin` (dB), or a closed loop's
    own mode damped below `min_damping`, is flagged and ranked after every healthy one.
    """
    pairs = [(str(k), [float(v) for v in values]) for k, values in grid.items()]
    text = _native.sweep(
        load_program(program),
        load_machine(machine),
        pairs,
        profile,
        cycle_ms,
        min_damping,
        min_phase_margin,
        min_gain_margin,
    )
    return SweepResult(text)


def diagnose(
    program: Optional[ProgramLike],
    measured: TraceLike,
    machine: MachineLike = None,
    *,
    second: Optional[TraceLike] = None,
    causes: Optional[Sequence[str]] = None,
    exclude: Optional[Sequence[str]] = None,
    max_causes: int = 3,
    evidence: float = 10.0,
    measured_at: str = "table",
    align_stretches: bool = False,
    command_tolerance_um: float = 25.0,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    report: Optional[PathLike] = None,
) -> Diagnosis:
    """What the model gets wrong against a measurement, the physical cause and the fitted
    extension (``contourcheck diagnose``).

    Args:
        program: the program the record ran; None: the path its recorded commands drew.
        measured: the record (a :class:`Trace`, a path, or a dict of arrays).
        machine: the nominal machine.
        second: a second record of the program to judge the causes on.
        causes, exclude: cause ids to try only / never (``backlash``, ``kv_gain``, …).
        measured_at: ``"table"``, ``"motor"`` or ``"tool"``.
        report: write the one-page HTML report there.

    Returns:
        A :class:`Diagnosis`: causes with their values and uncertainties, the verdict, the
        extended machine as TOML text.
    """
    native = _native.diagnose(
        None if program is None else load_program(program),
        load_machine(machine),
        _trace(measured),
        _trace(second),
        None if causes is None else list(causes),
        None if exclude is None else list(exclude),
        max_causes,
        evidence,
        measured_at,
        align_stretches,
        command_tolerance_um,
        profile,
        cycle_ms,
    )
    return _report(Diagnosis(native), report)


def identify(
    program: Optional[ProgramLike],
    measured: TraceLike,
    template: MachineLike = "hvmc",
    *,
    command_tolerance_um: float = 25.0,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    measured_at: str = "table",
    report: Optional[PathLike] = None,
) -> Identification:
    """A machine fitted to a record with its commands (``contourcheck identify``).

    Args:
        program: the program the record ran; None: the path its commands drew.
        measured: the record, with its commands.
        template: where to start (see :func:`load_machine`); ``"none"``: no template, a model of
            each loop from command to position.
        measured_at: where the record read the positions, ``"table"`` (a linear scale),
            ``"motor"`` (the motor's encoder) or ``"tool"``: the model is compared there.
        report: write the one-page HTML report there.

    Returns:
        An :class:`Identification`: values with uncertainties per axis, residuals, the
        held-out figure, the machine file as TOML text.
    """
    start = None if isinstance(template, str) and template == "none" else load_machine(template)
    native = _native.identify(
        None if program is None else load_program(program),
        start,
        _trace(measured),
        command_tolerance_um,
        profile,
        cycle_ms,
        measured_at,
    )
    return _report(Identification(native), report)
