"""ptsa from Python: the PTSA pulse-torque rebalance loop, its noise and its calibration.

Each function calls the same Rust library as the ``ptsa`` command line, never the
program itself, and returns what the command's ``--json`` prints (as dicts and lists) or
numpy arrays. Units are the command line's: accelerations in cm/s², times in s.
A refusal raises :class:`PtsaError` with the command line's message (file, line,
column and what was expected).

    >>> import ptsa
    >>> ptsa.static([-1000.0, 0.0, 1000.0], seconds=0.1)[0]["indicated_cm_s2"]  # doctest: +SKIP
"""

from __future__ import annotations

import json
import os
import tempfile
from typing import Any, Mapping, Sequence, Union

import numpy as np

from . import _ptsa
from ._ptsa import PtsaError

__all__ = [
    "PtsaError",
    "static",
    "record",
    "noise",
    "noise_text",
    "instrument_text",
    "discover",
    "correct",
    "yield_plan",
    "yield_units",
    "yield_summary",
    "yield_study",
]

PathLike = Union[str, "os.PathLike[str]"]
# An instrument: a file's path, a shipped name (`mems`, `navigation`), or a file's name and
# its text as a pair (what a campaign's task gets on a machine without the file).
Instrument = Union[PathLike, "tuple[str, str]"]


def _path(p: PathLike | None) -> str | None:
    return None if p is None else os.fspath(p)


def _instrument(p: Instrument | None) -> str | tuple[str, str] | None:
    if isinstance(p, tuple):
        if len(p) != 2:
            raise PtsaError(f"instrument: a pair of {len(p)}; expected (name, text)")
        return (str(p[0]), str(p[1]))
    return _path(p)


def instrument_text(instrument: Instrument | None) -> Instrument | None:
    """``instrument`` as a task on another machine can use it: a file's path becomes the
    pair (its path, its text), so the file need not be on that machine; a shipped name, a
    pair or None stay as they are."""
    if instrument is None or isinstance(instrument, tuple):
        return instrument
    path = os.fspath(instrument)
    if not os.path.exists(path):
        return path  # a shipped name, or a file the library will say it cannot find
    return (path, _decoded(path, _read(path), "an instrument file (TOML)"))


def static(
    accels_cm_s2: Sequence[float] | np.ndarray,
    seconds: float = 1.0,
    *,
    warmup_s: float | None = None,
    instrument: Instrument | None = None,
    seed: int | None = None,
    with_bias: bool = False,
) -> list[dict[str, Any]]:
    """The closed loop under constant accelerations along IA: ``ptsa static --json``.

    One gate after the settling at each acceleration, all run as one batch of the batch
    engine (each lane bit for bit the single loop's); the GIL is released while it runs.

    Args:
        accels_cm_s2: accelerations along IA, cm/s² (beyond full scale the loop
            saturates, and the result says so).
        seconds: the gate, s (at least one limit cycle, 0.001 s at 64 kHz).
        warmup_s: settling before the gate, s; None: the command line's default.
        instrument: an instrument file or a shipped name (``mems``, ...); None: the
            Kearfott 2401 of R-890.
        seed: seed of the pickoff noise (0 to 2**64 - 1); None: the default.
        with_bias: include the instrument file's bias A_b as a torque.

    Returns:
        One dict per acceleration, in order: the objects of ``ptsa static --json``
        (``ticks``, ``pulses``, ``indicated_cm_s2`` in cm/s², ``saturated``; every key:
        docs/reference/json.md).
    """
    accels = [float(a) for a in np.atleast_1d(np.asarray(accels_cm_s2, dtype=float))]
    text = _ptsa.static_json(
        accels, float(seconds), warmup_s, _instrument(instrument), seed, bool(with_bias)
    )
    return json.loads(text)


def record(
    seconds: float,
    gate_s: float | None = None,
    *,
    warmup_s: float | None = None,
    instrument: Instrument | None = None,
    seed: int | None = None,
) -> dict[str, np.ndarray]:
    """A simulated counter record of the loop at rest: ``ptsa noise --simulate --output``.

    Gates of ``gate_s`` back to back for ``seconds`` after the settling, the loop's bias
    and pickoff noise included.

    Args:
        seconds: the record's length after the settling, s.
        gate_s: the gate, s (at least one limit cycle); None: the command line's default
            (``ptsa noise --gate-s``, 0.01 s).
        warmup_s: settling from reset before the first gate, s; None: the default.
        instrument: an instrument file or a shipped name; None: the Kearfott 2401.
        seed: seed of the pickoff noise; None: the default.

    Returns:
        ``{"time_s": float64 (s, from the end of the settling), "pulses": uint64 (data
        pulses per gate), "ticks": uint64 (clock ticks per gate)}``, the columns of the
        record the command writes.
    """
    gate = None if gate_s is None else float(gate_s)
    t, p, k = _ptsa.record(float(seconds), gate, warmup_s, _instrument(instrument), seed)
    return {"time_s": t, "pulses": p, "ticks": k}


def _column(data: Any, name: str) -> np.ndarray | None:
    try:
        col = data[name]
    except (KeyError, IndexError, TypeError):
        return None
    return np.asarray(col)


def noise(
    data: Any,
    *,
    name: str = "<array>",
    unit: str | None = None,
    instrument: Instrument | None = None,
    spacing_tol: float | None = None,
    taus: str | Sequence[float] = "octave",
    confidence: float = 0.95,
    compare: bool = False,
    identify: bool = False,
    seed: int | None = None,
    warmup_s: float | None = None,
) -> dict[str, Any]:
    """The Allan analysis of a static record: ``ptsa noise --readings/--counts --json``.

    Args:
        data: a pandas DataFrame or a dict of arrays with the columns of a record of
            readings (``time_s`` in s, ``reading`` in ``unit``) or of a counter record
            (``time_s`` in s, ``pulses``, ``ticks``); or the path of such a CSV file.
        name: the record's name in messages and in the JSON's ``record`` (a path's own).
        unit: the readings' unit (``cm/s2``, ``m/s2``, ``g``, ``V``, ``mA``, ``LSB``);
            None: the instrument file's ``reading_unit``, else cm/s².
        instrument: an instrument file or a shipped name; None: the Kearfott 2401.
        spacing_tol: tolerance on each spacing of the readings, a fraction of the median
            spacing; None: the default.
        taus: ``"octave"``, ``"decade"``, ``"all"``, or averaging times in s.
        confidence: the second confidence level of the intervals (0 to 1, exclusive).
        compare: ``--compare``, a counter record only: the instrument file's loop simulated
            as long as the record, at its mean, and the deviations compared tau by tau.
            Takes ``taus="octave"``.
        identify: ``--identify``. A counter record: the white acceleration noise, the bias
            random walk and the pickoff noise its loop needs beyond the instrument file's,
            by simulating the loop (seconds to minutes). Readings: which of IEEE Std 952's
            terms they hold. Takes ``taus="octave"``.
        seed: with ``compare`` or ``identify``: the seed of the simulated noise (None: the
            command's).
        warmup_s: with ``compare`` or ``identify`` on a counter record: the simulations'
            settling, s (None: the command's).

    Returns:
        The object ``ptsa noise --json`` prints: the record's figures, one point per tau
        (deviations and intervals in cm/s²) and the noise terms (every key:
        docs/reference/json.md); with ``compare``, its ``comparison``; with ``identify``,
        its ``identification`` (counts) or ``terms_identification`` (readings).

    Raises:
        PtsaError: the record is refused (a gap, too few samples...); the row named is
            the line of the record as a CSV, its header being line 1.
    """
    options = dict(
        unit=unit, instrument=instrument, spacing_tol=spacing_tol, taus=taus,
        confidence=confidence, compare=compare, identify=identify, seed=seed, warmup_s=warmup_s,
    )
    if isinstance(data, (str, os.PathLike)):
        # The file as the command line reads it: its own lines and columns in messages.
        path = os.fspath(data)
        return noise_text(path if name == "<array>" else name, _decoded(path, _read(path)), **options)
    t = _column(data, "time_s")
    reading = _column(data, "reading")
    pulses, ticks = _column(data, "pulses"), _column(data, "ticks")
    if t is None or (reading is None and (pulses is None or ticks is None)):
        raise PtsaError(
            f"{name}: expected the columns time_s and reading (a record of readings) "
            "or time_s, pulses and ticks (a counter record)"
        )
    counts = reading is None
    names = ["time_s", "pulses", "ticks"] if counts else ["time_s", "reading"]
    cols = [t, pulses, ticks] if counts else [t, reading]
    text = _ptsa.columns_csv(names, [np.ascontiguousarray(c, dtype=np.float64) for c in cols])
    return noise_text(name, text, **options)


def noise_text(
    name: str,
    text: str,
    *,
    unit: str | None = None,
    instrument: Instrument | None = None,
    spacing_tol: float | None = None,
    taus: str | Sequence[float] = "octave",
    confidence: float = 0.95,
    compare: bool = False,
    identify: bool = False,
    seed: int | None = None,
    warmup_s: float | None = None,
) -> dict[str, Any]:
    """:func:`noise` of a record given as the text of its CSV file, ``name`` in messages:
    a counter record if its header is ``time_s,pulses,ticks``, else readings. What a
    campaign's task receives, so that the file need not be on the worker's disk."""
    return json.loads(
        _noise_json(
            name, text, unit=unit, instrument=instrument, spacing_tol=spacing_tol, taus=taus,
            confidence=confidence, compare=compare, identify=identify, seed=seed,
            warmup_s=warmup_s,
        )
    )


def _taus(taus: str | Sequence[float]) -> Any:
    return taus if isinstance(taus, str) else [float(t) for t in taus]


def _noise_json(name: str, text: str, **o: Any) -> str:
    """:func:`noise_text`'s JSON as the command line prints it, byte for byte."""
    counts = _header(text) == ["time_s", "pulses", "ticks"]
    return _ptsa.noise_json(
        name,
        text,
        counts,
        o["unit"],
        _instrument(o["instrument"]),
        o["spacing_tol"],
        _taus(o["taus"]),
        float(o["confidence"]),
        bool(o["compare"]),
        bool(o["identify"]),
        o["seed"],
        o["warmup_s"],
    )


def _seed_checked(seed: int) -> int:
    """``seed``, refused unless the library can take it."""
    if not 0 <= seed < 2**64:
        raise PtsaError(f"seed {seed}: expected a whole number from 0 to 2^64 - 1")
    return int(seed)


def _noise_check(
    *,
    unit: str | None = None,
    instrument: Instrument | None = None,
    spacing_tol: float | None = None,
    taus: str | Sequence[float] = "octave",
    confidence: float = 0.95,
    compare: bool = False,
    identify: bool = False,
    seed: int | None = None,
    warmup_s: float | None = None,
) -> None:
    """:func:`noise_text`'s options checked without a record (a campaign, before its
    tasks); ``spacing_tol`` is checked with each record of readings."""
    if seed is not None:
        _seed_checked(seed)
    _ptsa.noise_check(
        _instrument(instrument), unit, _taus(taus), float(confidence), bool(compare), bool(identify),
        warmup_s,
    )


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as e:
        raise PtsaError(f"{path}: cannot read: {e.strerror}") from None


def _decoded(name: str, data: bytes, what: str = "a CSV record") -> str:
    """A file's bytes as text, its line ends kept as the command line keeps them; bytes
    that are not UTF-8 refused at their line."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise PtsaError(
            f"{name}:{line}: not UTF-8 text (a bad byte at byte offset {e.start}); "
            f"expected {what} in UTF-8"
        ) from None


def _header(text: str) -> list[str]:
    """The cells of the first line that is neither blank nor a comment."""
    for line in text.lstrip("\ufeff").splitlines():
        t = line.strip()
        if t and not t.startswith("#"):
            return [c.strip() for c in t.split(",")]
    return []


def discover(
    data: Any,
    *,
    instrument: Instrument | None = None,
    analytic: bool = False,
    seed: int | None = None,
    sigma_cm_s2: float | None = None,
    keep_outliers: bool = False,
) -> dict[str, Any]:
    """Calibrate and discover from a case frame: ``ptsa discover --data FILE --json``.

    Args:
        data: the path of a case-frame CSV (docs/reference/case-frame-format.md), or a
            pandas DataFrame or a dict of equal-length arrays with its columns (written
            to a temporary file, read by the same reader).
        instrument: an instrument file or a shipped name; None: the Kearfott 2401.
        analytic: analyse on the quasi-static analytic model instead of the closed loop.
        seed: seed of the simulated loop's pickoff noise; None: the default.
        sigma_cm_s2: the rows' standard deviation, cm/s², where the data give none.
        keep_outliers: keep the rows the analysis would set aside as outliers.

    Returns:
        The object ``ptsa discover --json`` prints (the calibration's values and
        uncertainties, each candidate's test, the advice; every key:
        docs/reference/json.md).
    """
    args = (_instrument(instrument), bool(analytic), seed, sigma_cm_s2, bool(keep_outliers))
    if isinstance(data, (str, os.PathLike)):
        return json.loads(_ptsa.discover_json(os.fspath(data), *args))
    with tempfile.TemporaryDirectory(prefix="ptsa-") as d:
        path, name = _frame_file(data, d, "discover")
        names = {path: name}
        with _named(names):
            return _renamed(json.loads(_ptsa.discover_json(path, *args)), names)


def correct(
    data: Any,
    calibration: PathLike | Mapping[str, Any] | None = None,
    *,
    instrument: Instrument | None = None,
    sigma: float | None = None,
    local_gravity_cm_s2: float | None = None,
) -> dict[str, Any]:
    """A calibration applied to a record: ``ptsa correct --data FILE --json``.

    Args:
        data: the record: a path, a pandas DataFrame or a dict of arrays. A single-axis
            case frame (each row a reading in ``measured_cm_s2`` or counts in ``pulses``
            and ``ticks``, with ``g_pa`` and ``g_oa`` in g), or a triad record (each row
            ``measured_x_cm_s2``, ``measured_y_cm_s2``, ``measured_z_cm_s2`` or each axis's
            counts).
        calibration: what ``ptsa.discover`` returned (a dict), or the path of a
            ``ptsa discover --json`` file or, for a triad, of its calibration file; None:
            the instrument file's own model (a single axis only; then ``instrument`` is
            required).
        instrument: the instrument file the calibration was made with, or a shipped name.
        sigma: the noise of a reading that states none, cm/s² (1 sigma).
        local_gravity_cm_s2: the test stand's local gravity, cm/s² (970 to 990).

    Returns:
        The object ``ptsa correct --json`` prints: each row's specific force along IA (a
        triad: its three axes in the calibration's frame, with their covariance) in cm/s²
        and g with its 1-sigma uncertainty, and the warnings.
    """
    with tempfile.TemporaryDirectory(prefix="ptsa-") as d:
        names = {}
        if isinstance(calibration, Mapping):
            path = os.path.join(d, "calibration.json")
            try:
                text = json.dumps(calibration, allow_nan=False)
            except (TypeError, ValueError) as e:
                raise PtsaError(f"correct: the calibration dict is not plain JSON ({e}); expected what ptsa.discover returns") from None
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
            names[path] = "<calibration dict>"
            calibration = path
        if not isinstance(data, (str, os.PathLike)):
            data, names[data] = _frame_file(data, d, "correct")
        with _named(names):
            return _renamed(
                json.loads(
                    _ptsa.correct_json(
                        os.fspath(data), _path(calibration), _instrument(instrument), sigma, local_gravity_cm_s2
                    )
                ),
                names,
            )


class _named:
    """Within it, a PtsaError names the caller's frame or dict, not its temporary file."""

    def __init__(self, names: Mapping[str, str]):
        self.names = names

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: Any, e: Any, tb: Any) -> bool:
        if isinstance(e, PtsaError) and self.names:
            raise PtsaError(_renamed(str(e), self.names)) from None
        return False


def _renamed(v: Any, names: Mapping[str, str]) -> Any:
    """``v`` with every temporary file's path replaced by what the caller gave."""
    if isinstance(v, str):
        for path, name in names.items():
            v = v.replace(path, name)
        return v
    if isinstance(v, list):
        return [_renamed(x, names) for x in v]
    if isinstance(v, dict):
        return {k: _renamed(x, names) for k, x in v.items()}
    return v


def _frame_file(data: Any, d: str, what: str) -> tuple[str, str]:
    """A DataFrame or a dict of arrays written as a case-frame file in the folder ``d``:
    its path, and the name messages give it (``<DataFrame>`` or ``<dict>``)."""
    kind = "DataFrame"
    if isinstance(data, Mapping):
        import pandas as pd

        data = pd.DataFrame({k: np.asarray(v) for k, v in data.items()})
        kind = "dict"
    if not hasattr(data, "to_csv"):
        raise PtsaError(
            f"{what}: a {type(data).__name__}; expected a path, a pandas DataFrame or a dict of arrays"
        )
    path = os.path.join(d, "data.case.csv")
    data.to_csv(path, index=False)
    return path, f"<{kind}>"


def yield_plan(
    instruments: int,
    *,
    instrument: Instrument | None = None,
    seed: int | None = None,
    warmup_s: float | None = None,
    fractions: Sequence[float] | None = None,
    gate_s: float | None = None,
    gates: int | None = None,
    spec_sf_ppm: float | None = None,
    spec_bias_cm_s2: float | None = None,
    spec_linearity_ppm_fs: float | None = None,
    spec_noise_cm_s2: float | None = None,
    spec_pm_deg: float | None = None,
    spec_gm_db: float | None = None,
) -> dict[str, Any]:
    """The plan of a yield study, checked as ``ptsa monte-carlo --yield N`` checks it.

    Options left at None take the command line's defaults (``ptsa monte-carlo --help``).
    The keys are the JSON's ``plan`` (docs/reference/json.md).
    """
    spec = (
        spec_sf_ppm,
        spec_bias_cm_s2,
        spec_linearity_ppm_fs,
        spec_noise_cm_s2,
        spec_pm_deg,
        spec_gm_db,
    )
    return json.loads(
        _ptsa.yield_plan_json(
            int(instruments),
            _instrument(instrument),
            seed,
            warmup_s,
            None if fractions is None else [float(f) for f in fractions],
            gate_s,
            gates,
            spec,
        )
    )


def yield_units(
    plan: Mapping[str, Any], start: int, count: int, *, instrument: Instrument | None = None
) -> list[dict[str, Any]]:
    """Instruments ``start`` to ``start + count - 1`` of the study ``plan``, each run through
    the closed loop. An instrument depends on the plan's seed and its index only, so pieces
    computed anywhere (threads, processes, Ray tasks) join into the same study."""
    return json.loads(
        _ptsa.yield_units_json(json.dumps(plan), _instrument(instrument), int(start), int(count))
    )


def yield_summary(
    plan: Mapping[str, Any],
    units: Sequence[Mapping[str, Any]],
    *,
    instrument: Instrument | None = None,
) -> dict[str, Any]:
    """The study's report from its instruments, in any order: ``ptsa monte-carlo --yield
    N --json``'s object."""
    return json.loads(
        _ptsa.yield_summary_json(json.dumps(plan), _instrument(instrument), json.dumps(list(units)))
    )


def yield_study(instruments: int, *, instrument: Instrument | None = None, **options: Any) -> dict[str, Any]:
    """The production yield over the tolerance box: ``ptsa monte-carlo --yield N --json``.

    Args:
        instruments: instruments drawn from the box (each toleranced parameter uniform
            between its limits).
        instrument: an instrument file with a tolerance box, or a shipped name; None: the
            Kearfott 2401 and R-890's Table 2.1.
        options: those of :func:`yield_plan` (``seed``, ``warmup_s`` in s, ``fractions``
            of full scale, ``gate_s`` in s, ``gates``, ``spec_sf_ppm``,
            ``spec_bias_cm_s2``, ``spec_linearity_ppm_fs``, ``spec_noise_cm_s2``,
            ``spec_pm_deg``, ``spec_gm_db``).

    Returns:
        The plan, the yield with its 95 % Clopper-Pearson interval, each figure's
        distribution and every instrument (docs/reference/json.md).
    """
    plan = yield_plan(instruments, instrument=instrument, **options)
    units = yield_units(plan, 0, plan["instruments"], instrument=instrument)
    return yield_summary(plan, units, instrument=instrument)
