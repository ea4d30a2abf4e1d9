"""Ctrl-C stops a long call: the library's work is cancelled at its next checkpoint, the
call raises KeyboardInterrupt, and the next call runs."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

SCRIPT = """
import time, ptsa
print("started", flush=True)
t = time.perf_counter()
try:
    ptsa.record(86400.0, gate_s=1.0)  # a day of the loop: about a minute of work here
    print("not interrupted", flush=True)
except KeyboardInterrupt:
    print(f"interrupted after {time.perf_counter() - t:.2f} s", flush=True)
print("again", len(ptsa.static([0.0], 0.01)), flush=True)
"""


def interrupted(script: str) -> tuple[list[str], float]:
    """Run ``script``, Ctrl-C one second after it prints ``started``: its lines, and the
    seconds from Ctrl-C to its end."""
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=os.environ)
    assert p.stdout is not None
    assert p.stdout.readline() == "started\n"
    time.sleep(1.0)
    sent = time.perf_counter()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    waited = time.perf_counter() - sent
    assert p.returncode == 0, err
    return out.splitlines(), waited


def test_ctrl_c_stops_a_long_simulation_and_the_next_call_runs():
    lines, waited = interrupted(SCRIPT)
    assert lines[0].startswith("interrupted after"), lines
    assert lines[1] == "again 1"
    # Stopped within a fraction of a second, not at the end of the day's simulation.
    assert waited < 5.0, f"{waited:.2f} s from Ctrl-C to the end of the process"


def test_a_long_call_says_it_is_running_once_a_period():
    # PTSA_PROGRESS_S as the command line reads it: a line every 0.3 s instead of 10 s.
    script = "import ptsa; ptsa.record(3600.0, gate_s=1.0); print('done')"
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                       env={**os.environ, "PTSA_PROGRESS_S": "0.3"}, timeout=120)
    assert r.returncode == 0 and r.stdout == "done\n", r.stderr
    lines = [l for l in r.stderr.splitlines() if l.startswith("progress: ptsa.record: running, ")]
    assert len(lines) >= 2, r.stderr
    assert lines[0].endswith(" s elapsed")


def test_ctrl_c_stops_an_analytic_campaign_between_its_sets():
    # 18 kinds of 300 sets on the analytic model: about a minute here, no closed loop.
    script = """
from ptsa import campaign
print("started", flush=True)
try:
    campaign.hidden("effects", sets=300, seed=1, analytic=True)
    print("not interrupted", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""
    lines, waited = interrupted(script)
    assert lines == ["interrupted"]
    assert waited < 5.0, f"{waited:.2f} s from Ctrl-C to the end of the process"
