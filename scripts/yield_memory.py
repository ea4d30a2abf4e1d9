#!/usr/bin/env python3
"""What a yield study's driver holds, per instrument: the pieces' JSON text and the rise in
peak memory while the library makes the report from it.

    PYTHONPATH=target/python/site python3 scripts/yield_memory.py [N]

(`cargo xtask python` puts the package in target/python/site.) It runs N instruments
(default 4000; two 20 ms gates at each input, so it takes seconds) in pieces of 500, in
this process, as `python -m ptsa.campaign monte-carlo --ray none` does, then makes the
report from the pieces' text as the campaign's driver does after Ray. Peak memory is
`ru_maxrss` (Linux: kB), read before and after the report.
"""
import json
import resource
import sys

import ptsa
from ptsa import campaign


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    plan = json.dumps(ptsa.yield_plan(n, seed=3, gates=2, gate_s=0.02))
    texts = [campaign._units_task(plan, s, c, None) for s, c in campaign.pieces(n, 500)]
    held = sum(len(t) for t in texts)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    report = campaign._summary_text(plan, None, texts)
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(f"instruments: {n}")
    print(f"pieces' text held by the driver: {held / n:.0f} B per instrument")
    print(f"peak memory's rise while the report is made: {(after - before) * 1024 / n:.0f} B per instrument")
    print(f"the report's text: {len(report) / n:.0f} B per instrument")


if __name__ == "__main__":
    main()
