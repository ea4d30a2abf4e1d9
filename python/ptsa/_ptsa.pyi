"""Type stubs of the native module (python/src/lib.rs); call the functions of `ptsa`."""

from typing import Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

class PtsaError(ValueError):
    """A refusal of ptsa's library, with the command line's message."""

def defaults() -> tuple[float, int, float]:
    """(warmup_s in s, seed, spacing_tol as a fraction): the command line's defaults."""

def static_json(
    accels_cm_s2: Sequence[float],
    seconds: float,
    warmup_s: Optional[float],
    instrument: Optional[Union[str, tuple[str, str]]],
    seed: Optional[int],
    with_bias: bool,
) -> str: ...
def record(
    seconds: float,
    gate_s: Optional[float],
    warmup_s: Optional[float],
    instrument: Optional[Union[str, tuple[str, str]]],
    seed: Optional[int],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.uint64], npt.NDArray[np.uint64]]: ...
def columns_csv(names: Sequence[str], columns: Sequence[npt.NDArray[np.float64]]) -> str: ...
def noise_json(
    name: str,
    text: str,
    counts: bool,
    unit: Optional[str],
    instrument: Optional[Union[str, tuple[str, str]]],
    spacing_tol: Optional[float],
    taus: Union[str, Sequence[float]],
    confidence: float,
    compare: bool,
    identify: bool,
    seed: Optional[int],
    warmup_s: Optional[float],
) -> str: ...
def noise_check(
    instrument: Optional[Union[str, tuple[str, str]]],
    unit: Optional[str],
    taus: Union[str, Sequence[float]],
    confidence: float,
    compare: bool,
    identify: bool,
    warmup_s: Optional[float],
) -> None: ...
def correct_json(
    data: str,
    calibration: Optional[str],
    instrument: Optional[Union[str, tuple[str, str]]],
    sigma: Optional[float],
    local_gravity_cm_s2: Optional[float],
) -> str: ...
def yield_plan_json(
    instruments: int,
    instrument: Optional[Union[str, tuple[str, str]]],
    seed: Optional[int],
    warmup_s: Optional[float],
    fractions: Optional[Sequence[float]],
    gate_s: Optional[float],
    gates: Optional[int],
    spec: tuple[Optional[float], ...],
) -> str: ...
def yield_units_json(plan_json: str, instrument: Optional[Union[str, tuple[str, str]]], start: int, count: int) -> str: ...
def yield_summary_json(plan_json: str, instrument: Optional[Union[str, tuple[str, str]]], units_json: str) -> str: ...
def hidden_names() -> list[str]: ...
def hidden_check(name: str, sets: int, seed: int, analytic: bool, additive: bool) -> None: ...
def hidden_part(name: str, sets: int, seed: int, analytic: bool, additive: bool, part: int, parts: int) -> bytes: ...
def hidden_gather(
    name: str, sets: int, seed: int, analytic: bool, additive: bool, shards: list[bytes], seconds: float
) -> tuple[str, str, str, list[str]]: ...
def hidden_whole(name: str, sets: int, seed: int, analytic: bool, additive: bool) -> tuple[str, str, str, list[str]]: ...
def discover_json(
    path: str,
    instrument: Optional[Union[str, tuple[str, str]]],
    analytic: bool,
    seed: Optional[int],
    sigma_cm_s2: Optional[float],
    keep_outliers: bool,
) -> str: ...
