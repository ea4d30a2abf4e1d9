"""Campaigns spread over Ray workers: ``python -m ptsa.campaign monte-carlo --yield N``.

The study is cut into tasks of ``--task-size`` instruments. Each task runs
:func:`ptsa.yield_units` on its own indices, and the driver joins the pieces with
:func:`ptsa.yield_summary`. An instrument depends on the seed and its index only, so the
JSON is the same as ``ptsa monte-carlo --yield N --json`` on one machine, whatever the
number of workers.

``--ray local`` (the default) starts Ray on this machine only; ``--ray auto`` joins the
cluster that ``ray start`` made (its address in RAY_ADDRESS); ``--ray none`` runs the
tasks one after another in this process, without Ray. No port is opened beyond the
machine unless the cluster you join has one.
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
    ray: str = "local",
    num_cpus: int | None = None,
    task_size: int = 64,
    instrument: str | None = None,
    **options: Any,
) -> dict[str, Any]:
    """:func:`ptsa.yield_study` with its instruments run as Ray tasks of ``task_size``.

    Args:
        ray: ``"local"`` (a Ray on this machine, bound to 127.0.0.1), ``"auto"`` (the
            running cluster) or ``"none"`` (no Ray: the tasks in turn, in this process).
        num_cpus: the CPUs a local Ray may use (None: all).
        task_size: instruments per task.
    """
    plan = ptsa.yield_plan(instruments, instrument=instrument, **options)
    parts = pieces(plan["instruments"], task_size)
    if ray == "none":
        units = [u for s, c in parts for u in ptsa.yield_units(plan, s, c, instrument=instrument)]
        return ptsa.yield_summary(plan, units, instrument=instrument)
    import ray as ray_mod

    started = not ray_mod.is_initialized()
    if started:
        if ray == "local":
            ray_mod.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
        else:
            ray_mod.init(address=ray, log_to_driver=False)
    try:
        task = ray_mod.remote(num_cpus=1)(_units_task)
        refs = [task.remote(plan, s, c, instrument) for s, c in parts]
        units = [u for piece in ray_mod.get(refs) for u in piece]
    finally:
        if started:
            ray_mod.shutdown()
    return ptsa.yield_summary(plan, units, instrument=instrument)


def _units_task(plan: dict[str, Any], start: int, count: int, instrument: str | None) -> list[dict[str, Any]]:
    """One Ray task: its instruments, run on one core (the batch engine's own threads
    limited to it)."""
    return ptsa.yield_units(plan, start, count, instrument=instrument)


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
    mc.add_argument("--gate-s", type=float, help="the gate at each input, s")
    mc.add_argument("--gates", type=int, help="gates at each input")
    for flag, unit in [("sf-ppm", "ppm"), ("bias-cm-s2", "cm/s^2"), ("linearity-ppm-fs", "ppm of full scale"),
                       ("noise-cm-s2", "cm/s^2"), ("pm-deg", "degrees"), ("gm-db", "dB")]:
        mc.add_argument(f"--spec-{flag}", type=float, help=f"a limit of the specification, {unit}")
    mc.add_argument("--ray", default="local",
                    help="local (a Ray on this machine, the default), auto (the running cluster), "
                         "an address, or none (no Ray)")
    mc.add_argument("--num-cpus", type=int, help="CPUs of a local Ray (default: all)")
    mc.add_argument("--task-size", type=int, default=64, help="instruments per task (default 64)")
    a = p.parse_args(argv)
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
