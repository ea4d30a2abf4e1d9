"""Campaigns spread over Ray workers: ``python -m ptsa.campaign monte-carlo --yield N``.

The study is cut into tasks of ``--task-size`` instruments. Each task runs
:func:`ptsa.yield_units` on its own indices, and the driver joins the pieces with
:func:`ptsa.yield_summary`. An instrument depends on the seed and its index only, so the
JSON is the same as ``ptsa monte-carlo --yield N --json`` on one machine, whatever the
number of workers.

``--ray none`` (the default) runs the tasks one after another in this process, without
Ray, and opens no port. ``--ray local`` starts a new Ray on this machine: its processes
listen on every interface of the machine (Ray's own choice), so use it on a machine whose
ports are closed to the outside. ``--ray auto`` joins the running cluster (RAY_ADDRESS,
or the one ``ray start`` made here); any other value is a cluster's address. An
instrument file must be at the same path on every node (or be a shipped name).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any, Sequence

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
    instrument: str | None = None,
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
    if task_size < 1:
        raise ptsa.PtsaError(f"task_size {task_size}: expected 1 or more instruments per task")
    plan = ptsa.yield_plan(instruments, instrument=instrument, **options)
    parts = pieces(plan["instruments"], task_size)
    if ray == "none":
        units = [u for s, c in parts for u in ptsa.yield_units(plan, s, c, instrument=instrument)]
        return ptsa.yield_summary(plan, units, instrument=instrument)
    import ray as ray_mod

    started = not ray_mod.is_initialized()
    if started:
        _start(ray_mod, ray, num_cpus)
    try:
        # One core per task: the batch engine's thread pool limited to it, so that Ray's
        # count of CPUs is the cores used.
        task = ray_mod.remote(num_cpus=1, runtime_env={"env_vars": {"RAYON_NUM_THREADS": "1"}})(
            _units_task
        )
        refs = [task.remote(plan, s, c, instrument) for s, c in parts]
        units = [u for piece in ray_mod.get(refs) for u in piece]
    finally:
        if started:
            ray_mod.shutdown()
    return ptsa.yield_summary(plan, units, instrument=instrument)


def _start(ray_mod: Any, ray: str, num_cpus: int | None) -> None:
    """Start (``local``) or join (``auto``, an address) a Ray."""
    if ray == "local":
        ray_mod.init(address="local", num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
    else:
        ray_mod.init(address=ray, log_to_driver=False)


def _units_task(plan: dict[str, Any], start: int, count: int, instrument: str | None) -> list[dict[str, Any]]:
    """One Ray task: its instruments, run on one core (the batch engine's own threads
    limited to it)."""
    return ptsa.yield_units(plan, start, count, instrument=instrument)


def bench(instruments: int, repeats: int, task_size: int, expect: float | None) -> dict[str, Any]:
    """The study on a local Ray of 1 and of 2 CPUs, ``repeats`` times each: the medians, the
    speed-up, one task's ticks and seconds. With ``expect``, the speed-up must reach it."""
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
        "task_size": task_size,
        "tasks": len(pieces(instruments, task_size)),
        "ticks_per_instrument": per_unit,
        "ticks_per_task": per_unit * task_size,
        "median_s": {},
    }
    for cpus in (1, 2):
        _start(ray_mod, "local", cpus)
        try:
            yield_study(8, task_size=4)  # the workers started before the clock runs
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                yield_study(instruments, task_size=task_size)
                times.append(time.perf_counter() - t0)
        finally:
            ray_mod.shutdown()
        out["median_s"][str(cpus)] = statistics.median(times)
    out["speedup_2_over_1"] = out["median_s"]["1"] / out["median_s"]["2"]
    out["seconds_per_task_1_cpu"] = out["median_s"]["1"] / out["tasks"]
    if expect is not None and out["speedup_2_over_1"] < expect:
        raise SystemExit(f"speed-up {out['speedup_2_over_1']:.3f} from 1 to 2 workers; expected at least {expect}")
    return out


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
    mc.add_argument("--ray", default="none",
                    help="none (no Ray, no port opened: the default), local (a new Ray on this "
                         "machine, listening on its interfaces), auto (the running cluster) or an address")
    mc.add_argument("--num-cpus", type=int, help="CPUs of a local Ray (default: all)")
    mc.add_argument("--task-size", type=int, default=64, help="instruments per task (default 64)")
    b = sub.add_parser("bench", help="the yield study on a local Ray of 1 and 2 CPUs: medians and speed-up")
    b.add_argument("--yield", dest="instruments", type=int, default=256, metavar="N")
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--task-size", type=int, default=16)
    b.add_argument("--expect-speedup", type=float, help="fail unless 2 workers are this much faster than 1")
    a = p.parse_args(argv)
    if a.campaign == "bench":
        print(json.dumps(bench(a.instruments, a.repeats, a.task_size, a.expect_speedup), indent=1))
        return 0
    options = {k: v for k, v in vars(a).items()
               if k not in ("campaign", "instruments", "ray", "num_cpus", "task_size", "instrument")
               and v is not None}
    try:
        out = yield_study(a.instruments, ray=a.ray, num_cpus=a.num_cpus, task_size=a.task_size,
                          instrument=a.instrument, **options)
    except ptsa.PtsaError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(json.dumps(out, separators=(",", ":")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
