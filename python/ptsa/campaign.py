"""Campaigns spread over Ray workers.

``python -m ptsa.campaign monte-carlo --yield N``: the yield study, cut into tasks of
``--task-size`` instruments. Each task runs
:func:`ptsa.yield_units` on its own indices, and the driver joins the pieces with
:func:`ptsa.yield_summary`. An instrument depends on the seed and its index only, so the
JSON is the same as ``ptsa monte-carlo --yield N --json`` on one machine, whatever the
number of workers.

``python -m ptsa.campaign noise FOLDER [--compare] [--identify]``: every record in a folder (a rack of
instruments, each a long static record), one task per record. Each record's JSON is,
byte for byte, the line ``ptsa noise --counts/--readings FILE --json`` prints, in the order
of the files' names; a record refused is an ``error:`` line and exit status 1, the others
printed. A record travels to its task as its bytes.

``python -m ptsa.campaign hidden NAME --sets N --seed S``: a hidden-effect or coverage
campaign of the analyses (``cargo xtask hidden``'s: ``effects``, ``statics``, ``params``,
``lab``, ``sigma``, ``calibration``, ``triad``, ``stability``), cut into ``--tasks``
shards. Shard ``p`` is the sets at positions ``p``, ``p + tasks``, ... in table order. Each
set depends on the seed, its kind and its index only. So the table and the ``--json`` line
are the same whatever the number of tasks or workers, but for wall times (the table's, the
triad's fits). What travels is five small values out and each shard's outcomes back, as
bytes.

``--ray none`` (the default) runs the tasks one after another in this process, without
Ray, and opens no port. ``--ray local`` starts a new Ray on this machine: its processes
listen on every interface of the machine (Ray's own choice), so use it on a machine whose
ports are closed to the outside. ``--ray auto`` joins the running cluster (RAY_ADDRESS,
or the one ``ray start`` made here); any other value is a cluster's address. An
instrument file travels to each task as its text (:func:`ptsa.instrument_text`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
from typing import Any, Iterator, Sequence

import ptsa


def pieces(n: int, size: int) -> list[tuple[int, int]]:
    """``(start, count)`` of each task: ``size`` instruments, the last one what is left."""
    return [(s, min(size, n - s)) for s in range(0, n, size)]


def yield_study(
    instruments: int,
    *,
    ray: str = "none",
    num_cpus: int | None = None,
    task_size: int = 64,
    instrument: ptsa.Instrument | None = None,
    **options: Any,
) -> dict[str, Any]:
    """:func:`ptsa.yield_study` with its instruments run as Ray tasks of ``task_size``.

    Args:
        ray: ``"none"`` (no Ray: the tasks in turn, in this process, no port opened),
            ``"local"`` (a new Ray on this machine, listening on its interfaces),
            ``"auto"`` (the running cluster) or a cluster's address.
        num_cpus: the CPUs a local Ray may use (None: all).
        task_size: instruments per task.
    """
    return json.loads(_yield_study_text(instruments, ray, num_cpus, task_size, instrument, options))


def _yield_study_text(
    instruments: int,
    ray: str,
    num_cpus: int | None,
    task_size: int,
    instrument: ptsa.Instrument | None,
    options: dict[str, Any],
) -> str:
    """:func:`yield_study`'s JSON text. Each task's instruments come back as the JSON text
    the library wrote (about 0.9 kB an instrument), never as Python objects, and the
    library reads them all at once: the driver holds the study as text."""
    if task_size < 1:
        raise ptsa.PtsaError(f"task_size {task_size}: expected 1 or more instruments per task")
    plan = ptsa.yield_plan(instruments, instrument=instrument, **options)
    parts = pieces(plan["instruments"], task_size)
    instrument = ptsa.instrument_text(instrument)
    plan_json = json.dumps(plan)
    if ray == "none":
        texts = [_units_task(plan_json, s, c, instrument) for s, c in parts]
        return _summary_text(plan_json, instrument, texts)
    with _ray_session(ray, num_cpus) as ray_mod:
        task = _one_core_task(ray_mod, _units_task)
        texts = ray_mod.get([task.remote(plan_json, s, c, instrument) for s, c in parts])
    return _summary_text(plan_json, instrument, texts)


def _summary_text(plan_json: str, instrument: ptsa.Instrument | None, texts: list[str]) -> str:
    """The study's JSON text from its pieces' JSON lists, joined as text."""
    joined = "[" + ",".join(t[1:-1] for t in texts if t != "[]") + "]"
    return ptsa._ptsa.yield_summary_json(plan_json, ptsa._instrument(instrument), joined)


@contextlib.contextmanager
def _ray_session(ray: str, num_cpus: int | None) -> Iterator[Any]:
    """The module ``ray``, joined to the Ray ``ray`` names (or to the one already
    initialised in this process, which is left running); a Ray started here is shut down
    on the way out."""
    import ray as ray_mod

    started = not ray_mod.is_initialized()
    if started:
        _start(ray_mod, ray, num_cpus)
    try:
        yield ray_mod
    finally:
        if started:
            ray_mod.shutdown()


def _one_core_task(ray_mod: Any, f: Any) -> Any:
    """``f`` as a Ray task on one core: the library's thread pool limited to it, so that
    Ray's count of CPUs is the cores used."""
    return ray_mod.remote(num_cpus=1, runtime_env={"env_vars": {"RAYON_NUM_THREADS": "1"}})(f)


def _start(ray_mod: Any, ray: str, num_cpus: int | None) -> None:
    """Start (``local``) or join (``auto``, an address) a Ray."""
    if ray == "local":
        ray_mod.init(address="local", num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
    else:
        ray_mod.init(address=ray, log_to_driver=False)


def _units_task(plan_json: str, start: int, count: int, instrument: ptsa.Instrument | None) -> str:
    """One Ray task: its instruments, run on one core (the batch engine's own threads
    limited to it), as the library's JSON list."""
    return ptsa._ptsa.yield_units_json(plan_json, ptsa._instrument(instrument), start, count)


def records_in(folder: str) -> list[str]:
    """The records of ``folder``: its ``.csv`` files (any case; not its subfolders'), in the
    order of their names."""
    try:
        names = sorted(n for n in os.listdir(folder) if n.lower().endswith(".csv"))
    except OSError as e:
        raise ptsa.PtsaError(f"{folder}: cannot read the folder: {e.strerror}") from None
    paths = [os.path.join(folder, n) for n in names]
    return [p for p in paths if os.path.isfile(p)]


def noise_folder(
    folder: str,
    *,
    ray: str = "none",
    num_cpus: int | None = None,
    **options: Any,
) -> list[dict[str, Any] | ptsa.PtsaError]:
    """:func:`ptsa.noise` of every record in ``folder`` (:func:`records_in`), one Ray task
    each, in the order of their names: each result the dict ``ptsa noise --json`` prints
    for that file, or the :class:`ptsa.PtsaError` that refused it.

    Args:
        ray: as :func:`yield_study`'s.
        num_cpus: the CPUs a local Ray may use (None: all).
        options: :func:`ptsa.noise`'s keywords (``compare``, ``identify``, ``taus``,
            ``instrument``...), checked once before any task starts.
    """
    return [r if isinstance(r, ptsa.PtsaError) else json.loads(r)
            for r in _noise_lines(folder, ray, num_cpus, options)]


def _noise_lines(
    folder: str, ray: str, num_cpus: int | None, options: dict[str, Any]
) -> list[str | ptsa.PtsaError]:
    """Each record's JSON text as the command line prints it, or its refusal."""
    defaults = _noise_defaults()
    unknown = sorted(set(options) - set(defaults))
    if unknown:
        raise ptsa.PtsaError(
            f"{', '.join(unknown)}: not an option of a record's analysis; expected {', '.join(defaults)}"
        )
    paths = records_in(folder)
    if not paths:
        raise ptsa.PtsaError(f"{folder}: no records (.csv files) in the folder")
    options = {**defaults, **options}
    options["instrument"] = ptsa.instrument_text(options["instrument"])
    ptsa._noise_check(**options)  # one refusal for all, before Ray starts
    if ray == "none":
        return [_noise_task(p, _bytes(p), options) for p in paths]
    with _ray_session(ray, num_cpus) as ray_mod:
        task = _one_core_task(ray_mod, _noise_task)
        # Each record read on the driver and sent to its task as bytes; one that cannot be
        # read is its refusal, not a task.
        refs = []
        for p in paths:
            data = _bytes(p)
            refs.append(data if isinstance(data, ptsa.PtsaError) else task.remote(p, data, options))
        return [_result(ray_mod, p, r) for p, r in zip(paths, refs)]


def _bytes(path: str) -> bytes | ptsa.PtsaError:
    try:
        return ptsa._read(path)
    except ptsa.PtsaError as e:
        return e


def _result(ray_mod: Any, name: str, ref: Any) -> str | ptsa.PtsaError:
    """A task's result, or its failure (a worker lost, a task killed) as the record's
    refusal: one task's fate never takes the others' results with it."""
    if isinstance(ref, ptsa.PtsaError):
        return ref
    try:
        return ray_mod.get(ref)
    except Exception as e:  # noqa: BLE001
        return ptsa.PtsaError(f"{name}: the task failed: {type(e).__name__}: {e}")


def _noise_defaults() -> dict[str, Any]:
    """:func:`ptsa.noise_text`'s keyword defaults."""
    import inspect

    sig = inspect.signature(ptsa.noise_text)
    return {k: p.default for k, p in sig.parameters.items() if p.kind is p.KEYWORD_ONLY}


def _noise_task(name: str, data: bytes | ptsa.PtsaError, options: dict[str, Any]) -> str | ptsa.PtsaError:
    """One record's analysis, from its bytes: its JSON text, or the error that refused it,
    named by the record."""
    if isinstance(data, ptsa.PtsaError):
        return data
    try:
        return ptsa._noise_json(name, ptsa._decoded(name, data), **options)
    except ptsa.PtsaError as e:
        m = str(e)
        return e if m.startswith(name) else ptsa.PtsaError(f"{name}: {m}")
    except BaseException as e:  # a record's failure (a Rust panic included) keeps the others'
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        return ptsa.PtsaError(f"{name}: {type(e).__name__}: {e}")


class HiddenRun(dict):
    """A campaign put together, as a dict.

    ``json`` is the dict the ``--json`` line holds (every set's outcome in table order, and
    the ``failures``); ``text`` is that line. ``notable`` lists the sets that matter for the
    rates (naming campaigns only). ``table`` is the campaign's table, and ``failures`` the
    asserted rates not met (empty: the campaign passes)."""


def hidden(
    name: str,
    *,
    sets: int,
    seed: int,
    analytic: bool = False,
    additive: bool = False,
    ray: str = "none",
    num_cpus: int | None = None,
    tasks: int = 64,
    progress: bool = False,
) -> HiddenRun:
    """The campaign ``name`` (:func:`hidden_names`), ``sets`` sets of every kind
    (``calibration``, ``stability``: in all), in ``tasks`` shards, each a Ray task on one
    core.

    Args:
        analytic: ``effects`` and ``lab``: data from the quasi-static model, analysed with
            the analytic simulator (fast, no loop dynamics).
        additive: ``statics``: the loop's parameters left out of the vocabulary.
        ray: as :func:`yield_study`'s; ``"none"`` runs the whole campaign in this process
            on every core.
        tasks: shards, one Ray task each (a shard beyond the campaign's sets is empty); not
            used with ``ray="none"``.
        progress: a line on standard error as each shard ends.
    """
    import time

    _ptsa = ptsa._ptsa
    if tasks < 1:
        raise ptsa.PtsaError(f"tasks {tasks}: expected 1 or more")
    # Any count below 1 is refused as 0 is, by the library.
    key = (name, max(int(sets), 0), ptsa._seed_checked(seed), bool(analytic), bool(additive))
    _ptsa.hidden_check(*key)  # one refusal for all, before Ray starts
    if ray == "none":
        return _hidden_run(_ptsa.hidden_whole(*key))
    t0 = time.perf_counter()
    with _ray_session(ray, num_cpus) as ray_mod:
        task = _one_core_task(ray_mod, _ptsa_hidden_part)
        refs = [task.remote(key, p, tasks) for p in range(tasks)]
        try:
            _wait(ray_mod, refs, "shards", progress)
            shards = ray_mod.get(refs)
        except Exception as e:  # noqa: BLE001  (a task failed or its worker was lost)
            raise ptsa.PtsaError(f"{name}: a shard's task failed: {type(e).__name__}: {e}") from None
    return _hidden_run(_ptsa.hidden_gather(*key, shards, time.perf_counter() - t0))


def hidden_names() -> list[str]:
    """The campaigns :func:`hidden` runs."""
    return list(ptsa._ptsa.hidden_names())


def _ptsa_hidden_part(key: tuple[str, int, int, bool, bool], part: int, parts: int) -> bytes:
    """One Ray task: a shard of the campaign, on one core."""
    return ptsa._ptsa.hidden_part(*key, part, parts)


def _hidden_run(out: tuple[str, str, str, list[str]]) -> HiddenRun:
    text, notable, table, failures = out
    return HiddenRun(json=json.loads(text), text=text, notable=notable, table=table, failures=list(failures))


def _wait(ray_mod: Any, refs: list[Any], what: str, progress: bool) -> None:
    """Wait for every task, with a line on standard error as each ends."""
    pending = list(refs)
    while pending:
        done, pending = ray_mod.wait(pending, num_returns=1)
        if progress:
            print(f"\r{len(refs) - len(pending)}/{len(refs)} {what} done", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)


def bench(instruments: int, repeats: int, task_size: int, expect: float | None = None) -> dict[str, Any]:
    """The study on a local Ray of 1 and of 2 CPUs, ``repeats`` times each: the medians, the
    speed-up, one task's ticks and seconds, and ``expect`` (the speed-up asked for, kept
    with the figures)."""
    import statistics
    import time

    import ray as ray_mod

    plan = ptsa.yield_plan(instruments)
    clock_hz = 64000.0  # the shipped instrument's clock (data/kearfott-2401.toml)
    per_unit = len(plan["fractions_of_full_scale"]) * (
        plan["warmup_s"] + plan["gates"] * plan["gate_s"]
    ) * clock_hz
    out: dict[str, Any] = {
        "instruments": instruments,
        "repeats": repeats,
        "task_size": task_size,
        "tasks": len(pieces(instruments, task_size)),
        "ticks_per_instrument": per_unit,
        "ticks_per_task": per_unit * task_size,
        "median_s": {},
    }
    for cpus in (1, 2):
        _start(ray_mod, "local", cpus)
        try:
            yield_study(8, ray="auto", task_size=4)  # the workers started before the clock runs
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                yield_study(instruments, ray="auto", task_size=task_size)
                times.append(time.perf_counter() - t0)
        finally:
            ray_mod.shutdown()
        out["median_s"][str(cpus)] = statistics.median(times)
    out["speedup_2_over_1"] = out["median_s"]["1"] / out["median_s"]["2"]
    out["seconds_per_task_1_cpu"] = out["median_s"]["1"] / out["tasks"]
    out["expect_speedup"] = expect
    return out


def bench_lines(b: dict[str, Any]) -> str:
    """:func:`bench`'s figures as ``bench:`` lines, the speed-up last."""
    return "\n".join([
        f"bench: the yield study of {b['instruments']} instruments in {b['tasks']} tasks of {b['task_size']}, "
        f"on a local Ray of 1 and of 2 CPUs, {b['repeats']} runs each",
        f"bench: one task: {b['ticks_per_task']:.3g} clock ticks, {b['seconds_per_task_1_cpu']:.3f} s on one core",
        f"bench: 1 worker: median {b['median_s']['1']:.3f} s",
        f"bench: 2 workers: median {b['median_s']['2']:.3f} s",
        f"bench: 1 worker / 2 workers = {b['speedup_2_over_1']:.3f} (the speed-up)",
    ])


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m ptsa.campaign",
        description="ptsa's campaigns as Ray tasks; the JSON is the command line's.",
    )
    sub = p.add_subparsers(dest="campaign", required=True)
    mc = sub.add_parser("monte-carlo", help="the yield study of ptsa monte-carlo --yield N")
    mc.add_argument("--yield", dest="instruments", type=int, required=True, metavar="N",
                    help="instruments drawn from the tolerance box")
    mc.add_argument("--seed", type=int, help="seed of the draws (default: the command line's)")
    mc.add_argument("--instrument", help="an instrument file with a tolerance box, or a shipped name")
    mc.add_argument("--warmup-s", type=float, help="settling from reset before the first gate, s")
    mc.add_argument("--fractions", type=lambda v: [float(x) for x in v.split(",")],
                    help="the inputs along IA, fractions of full scale, comma separated")
    mc.add_argument("--gate-s", type=float, help="the gate at each input, s")
    mc.add_argument("--gates", type=int, help="gates at each input")
    for flag, unit in [("sf-ppm", "ppm"), ("bias-cm-s2", "cm/s^2"), ("linearity-ppm-fs", "ppm of full scale"),
                       ("noise-cm-s2", "cm/s^2"), ("pm-deg", "degrees"), ("gm-db", "dB")]:
        mc.add_argument(f"--spec-{flag}", type=float, help=f"a limit of the specification, {unit}")
    mc.add_argument("--task-size", type=int, default=64, help="instruments per task (default 64)")
    nz = sub.add_parser("noise", help="ptsa noise --json of every record (.csv) of a folder, a task each")
    nz.add_argument("folder", help="the folder of records: counter records or readings, one .csv each")
    nz.add_argument("--compare", action="store_true",
                    help="each counter record against the instrument file's loop, simulated (ptsa noise --compare); "
                         "a record of readings is refused")
    nz.add_argument("--identify", action="store_true",
                    help="what each record's noise needs beyond the instrument file's (ptsa noise --identify)")
    nz.add_argument("--instrument", help="an instrument file or a shipped name")
    nz.add_argument("--unit", help="the readings' unit: cm/s2, m/s2, g, V, mA or LSB")
    nz.add_argument("--confidence", type=float, help="the second confidence level, 0 to 1 (default 0.95)")
    nz.add_argument("--seed", type=int, help="with --compare or --identify: the seed of the simulated noise")
    nz.add_argument("--warmup-s", type=float, help="with --compare or --identify: the simulations' settling, s")
    hd = sub.add_parser("hidden", help="a hidden-effect or coverage campaign (cargo xtask hidden's), in shards")
    hd.add_argument("name", choices=hidden_names(),
                    help="effects (xtask hidden), statics (--statics), params (--parameters), lab (--lab), "
                         "sigma (--sigma), calibration (--calibration), triad (--triad), stability (--stability)")
    hd.add_argument("--sets", type=int, required=True,
                    help="sets per kind; calibration and stability: sets in all (cargo xtask help hidden "
                         "gives each campaign's published size)")
    hd.add_argument("--seed", type=int, required=True, help="the campaign's seed")
    hd.add_argument("--analytic", action="store_true",
                    help="effects, lab: data from the quasi-static model, analysed with the analytic simulator")
    hd.add_argument("--additive", action="store_true", help="statics: the loop's parameters out of the vocabulary")
    hd.add_argument("--tasks", type=int, default=64, help="with --ray: shards, one task each (default 64)")
    hd.add_argument("--json", action="store_true", help="print the JSON line (every set, the failures), not the table")
    for q in (mc, nz, hd):
        q.add_argument("--ray", default="none",
                       help="none (no Ray, no port opened: the default), local (a new Ray on this "
                            "machine, listening on its interfaces), auto (the running cluster) or an address")
        q.add_argument("--num-cpus", type=int, help="CPUs of a local Ray (default: all)")
    b = sub.add_parser("bench", help="the yield study on a local Ray of 1 and 2 CPUs: medians and speed-up")
    b.add_argument("--yield", dest="instruments", type=int, default=256, metavar="N")
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--task-size", type=int, default=16)
    b.add_argument("--expect-speedup", type=float,
                   help="exit 1 unless 2 workers are this much faster than 1 (the ratio of the medians)")
    b.add_argument("--json", action="store_true", help="print the figures as JSON, not as bench: lines")
    a = p.parse_args(argv)
    if a.campaign == "bench":
        out = bench(a.instruments, a.repeats, a.task_size, a.expect_speedup)
        print(json.dumps(out, indent=1) if a.json else bench_lines(out))
        if a.expect_speedup is not None and out["speedup_2_over_1"] < a.expect_speedup:
            print(f"error: speed-up {out['speedup_2_over_1']:.3f} from 1 to 2 workers; "
                  f"expected at least {a.expect_speedup}", file=sys.stderr)
            return 1
        return 0
    if a.campaign == "noise":
        return _noise_main(a)
    if a.campaign == "hidden":
        return _hidden_main(a)
    options = {k: v for k, v in vars(a).items()
               if k not in ("campaign", "instruments", "ray", "num_cpus", "task_size", "instrument")
               and v is not None}
    try:
        out = _yield_study_text(a.instruments, a.ray, a.num_cpus, a.task_size, a.instrument, options)
    except ptsa.PtsaError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(out)
    return 0


def _noise_main(a: argparse.Namespace) -> int:
    """``noise FOLDER``: a JSON line per record, an ``error:`` line per record refused."""
    options = {k: v for k, v in vars(a).items()
               if k in ("compare", "identify", "instrument", "unit", "confidence", "seed", "warmup_s") and v is not None}
    try:
        results = _noise_lines(a.folder, a.ray, a.num_cpus, options)
    except ptsa.PtsaError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    status = 0
    for r in results:
        if isinstance(r, ptsa.PtsaError):
            print(f"error: {r}", file=sys.stderr)
            status = 1
        else:
            print(r)
    return status


def _hidden_main(a: argparse.Namespace) -> int:
    """``hidden NAME``: the table (or the JSON line); exit 1 when an asserted rate is not met."""
    try:
        r = hidden(a.name, sets=a.sets, seed=a.seed, analytic=a.analytic, additive=a.additive,
                   ray=a.ray, num_cpus=a.num_cpus, tasks=a.tasks, progress=sys.stderr.isatty())
    except ptsa.PtsaError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    if a.json:
        print(r["text"])
    else:
        print(r["notable"], end="")
        print(r["table"], end="" if r["table"].endswith("\n") else "\n")
    return 1 if r["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
