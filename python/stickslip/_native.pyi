"""Type stubs of the compiled core (`python/src/lib.rs`). Use the functions of `stickslip`."""

from typing import Callable, Optional

import numpy as np
import numpy.typing as npt

def run(args: list[str]) -> tuple[str, Optional[dict[str, npt.NDArray[np.float64]]]]:
    """One case as `stickslip run ARGS --json`: the JSON text and the trace's channels."""

def trace_channels() -> list[tuple[str, str, str]]:
    """(name, unit, meaning) of each trace channel, in file order."""

def sweep(
    file: str,
    text: Optional[str],
    out: str,
    threads: Optional[int] = None,
    resume: bool = False,
    overwrite: bool = False,
    figures: bool = False,
    progress: Optional[Callable[[int, int, int], None]] = None,
) -> dict[str, object]:
    """A sweep into `out` (with its boundary); `progress(done, total, failed)` every 100 ms."""

def sweep_toml(json: str) -> str:
    """The TOML text of a sweep given as JSON."""

def boundary(path: str) -> tuple[list[str], list[list[float]]]:
    """The boundary CSV's columns and rows for a sweep file; writes nothing."""

def calibrate(args: list[str]) -> tuple[str, str]:
    """`stickslip calibrate ARGS`: the JSON text and the summary."""

def diagnose(args: list[str]) -> tuple[str, str, str, list[str]]:
    """`stickslip diagnose ARGS`: JSON text, report, output folder, files written."""

def check_campaign(dir: str) -> int:
    """Loads a campaign folder as the CLI does; the number of recordings."""

def parameters() -> list[tuple[str, str, str, float, str]]:
    """(name, CLI flag, unit, default, meaning) of every model parameter."""

def version() -> str:
    """The program version."""
