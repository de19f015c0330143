"""The exceptions contourcheck raises, each naming where the problem is.

Every exception is a :class:`ContourcheckError` and carries, where they apply, the ``file``,
``line`` and ``column`` (G-code programs, machine files), the ``key`` (machine files), the
``row`` (trace files: the file's 1-based line) or the ``sample`` (traces made from arrays:
the 0-based index).
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence

__all__ = [
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


class ContourcheckError(Exception):
    """Base of every contourcheck error.

    Attributes:
        message: what is wrong, as the command line says it.
        file: the file (or the name given to a text), where there is one.
        line, column: 1-based, in a program or a machine file.
        key: the machine file's dotted key.
        row: the trace file's 1-based line.
        sample: the 0-based index of a trace made from arrays.
        problems: for a program, every problem found: dicts with file, line, column, message.
    """

    def __init__(
        self,
        message: str,
        *,
        file: Optional[str] = None,
        line: Optional[int] = None,
        column: Optional[int] = None,
        key: Optional[str] = None,
        row: Optional[int] = None,
        sample: Optional[int] = None,
        problems: Sequence[Dict[str, Any]] = (),
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.key = key
        self.row = row
        self.sample = sample
        self.problems: List[Dict[str, Any]] = list(problems)


class ProgramError(ContourcheckError):
    """A program that cannot be read, or that does not fit the machine (file, line, column)."""


class MachineError(ContourcheckError):
    """A machine file or table that is wrong (file, key, line, column)."""


class TraceError(ContourcheckError):
    """A measured trace that cannot be read or is malformed (file, row or sample)."""


class SimulationError(ContourcheckError):
    """A machine that cannot be simulated: unstable gains, a run too long."""


class AnalysisError(ContourcheckError):
    """A record that cannot be placed on its program, diagnosed or identified."""


class UsageError(ContourcheckError, ValueError):
    """Arguments that make no sense (a value out of range, an unknown name)."""


class InputError(ContourcheckError):
    """An input file that cannot be read (file)."""


class ReportError(ContourcheckError):
    """An HTML report that could not be made."""
