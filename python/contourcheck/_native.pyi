"""Type stubs of the native module (Rust, PyO3): see the package's functions for the API."""

from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

def presets() -> List[str]: ...

class Machine:
    """A machine: the servo loops, drives, mechanics and friction of both axes."""

    @staticmethod
    def preset(name: str) -> Machine: ...
    @staticmethod
    def from_toml(text: str, name: str = "<text>") -> Machine: ...
    @staticmethod
    def from_file(path: str) -> Machine: ...
    @staticmethod
    def from_json(json: str, name: str = "<dict>") -> Machine: ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def file(self) -> Optional[str]: ...
    def to_toml(self) -> str: ...

class Program:
    """A part program, parsed and interpreted into its path."""

    @staticmethod
    def from_text(
        text: str, name: str = "<text>", dialect: Optional[str] = None, folder: Optional[str] = None
    ) -> Program: ...
    @staticmethod
    def from_file(path: str, dialect: Optional[str] = None) -> Program: ...
    @property
    def file(self) -> str: ...
    @property
    def lines(self) -> int: ...
    @property
    def blocks(self) -> int: ...
    @property
    def segments(self) -> int: ...
    @property
    def warnings(self) -> List[Tuple[int, str]]: ...
    def source_line(self, line: int) -> Tuple[Optional[str], int]: ...

class Trace:
    """A measured trace on a uniform time grid."""

    @property
    def file(self) -> str: ...
    @property
    def dt_s(self) -> float: ...
    def __len__(self) -> int: ...
    def arrays(self) -> Dict[str, npt.NDArray[np.float64]]: ...
    def columns(self) -> Dict[str, Dict[str, object]]: ...
    def describe(self) -> List[str]: ...

def read_trace(
    path: str, columns: Optional[str] = None, work_offset_mm: Optional[Tuple[float, float]] = None
) -> Trace: ...
def trace_from_arrays(
    t_s: npt.NDArray[np.float64],
    x_mm: npt.NDArray[np.float64],
    y_mm: npt.NDArray[np.float64],
    x_cmd_mm: Optional[npt.NDArray[np.float64]] = None,
    y_cmd_mm: Optional[npt.NDArray[np.float64]] = None,
    name: str = "<arrays>",
) -> Trace: ...

class CheckOutcome:
    def report_json(self) -> str: ...
    def samples(self) -> Dict[str, npt.NDArray[np.generic]]: ...
    def html(self) -> str: ...

class DiagnoseOutcome:
    def report_json(self) -> str: ...
    def machine_toml(self) -> str: ...
    def html(self) -> str: ...

class IdentifyOutcome:
    def report_json(self) -> str: ...
    def machine_toml(self) -> str: ...
    def html(self) -> str: ...

def check(
    program: Program,
    machine: Machine,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    blend_tolerance_mm: Optional[float] = None,
    tolerance_um: Optional[float] = None,
) -> CheckOutcome: ...
def sweep(
    program: Program,
    machine: Machine,
    grid: Sequence[Tuple[str, Sequence[float]]],
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    min_damping: float = 0.05,
    min_phase_margin: float = 30.0,
    min_gain_margin: float = 6.0,
) -> str: ...
def diagnose(
    program: Optional[Program],
    machine: Machine,
    trace: Trace,
    second: Optional[Trace] = None,
    causes: Optional[List[str]] = None,
    exclude: Optional[List[str]] = None,
    max_causes: int = 3,
    evidence: float = 10.0,
    measured_at: str = "table",
    align_stretches: bool = False,
    command_tolerance_um: float = 25.0,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
) -> DiagnoseOutcome: ...
def identify(
    program: Optional[Program],
    template: Optional[Machine],
    trace: Trace,
    command_tolerance_um: float = 25.0,
    profile: Optional[str] = None,
    cycle_ms: Optional[float] = None,
    measured_at: str = "table",
) -> IdentifyOutcome: ...
