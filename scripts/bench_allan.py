#!/usr/bin/env python3
"""Time `ptsa noise --readings` against allantools on the same CSV file, side by side.

    python3 scripts/bench_allan.py [--samples N] [--runs K] [--ptsa PATH] [--min-ratio R]

Writes a record of N white-noise readings (`time_s,reading`, g at 100 Hz, seeded) into a
temporary folder, then alternates K runs of each whole process, from the file to the
overlapping and modified Allan deviations at octave averaging times:

* ptsa: `PTSA --instrument mems noise --readings FILE --unit g --json` (g is then
  standard gravity, as here; it also computes the Hadamard
  deviation, Greenhall's EDF and intervals, the noise type per tau and the noise terms);
* allantools: a Python process that reads the file with numpy.loadtxt and calls
  allantools.oadev and allantools.mdev (taus="octave", data_type="freq"). Its time is given
  twice: the whole process, and the work alone (from reading the file to the second
  deviation, without the interpreter's start and the imports of numpy, scipy and
  allantools). The ratio is taken on the work alone, the comparison least kind to ptsa,
  whose time is always its whole process.

Prints the median times, their ratio, and the largest relative difference of
the two programs' deviations at the taus both report. Exit 1 when the ratio
(allantools / ptsa) is below --min-ratio (default 0: no threshold).

Needs numpy and allantools (`pip install allantools`, which brings numpy and scipy) and a
built `ptsa` (`cargo build --release -p ptsa-host-sim`; default target/release/ptsa).
Nothing is installed by this script.
"""
import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time

ALLANTOOLS = r"""
import sys, json, time
import numpy as np
import allantools
t0 = time.perf_counter()
y = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1, usecols=1)
t, ad, _, _ = allantools.oadev(y, rate=100.0, data_type="freq", taus="octave")
t2, md, _, _ = allantools.mdev(y, rate=100.0, data_type="freq", taus="octave")
work = time.perf_counter() - t0
print(json.dumps({"tau": list(t), "adev": list(ad), "tau_m": list(t2), "mdev": list(md),
                  "work_s": work}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=1_000_000, help="readings in the record")
    ap.add_argument("--runs", type=int, default=5, help="runs of each program")
    ap.add_argument("--ptsa", default=os.path.join(os.path.dirname(__file__), "..",
                                                   "target", "release", "ptsa"))
    ap.add_argument("--min-ratio", type=float, default=0.0,
                    help="fail below this allantools/ptsa time ratio")
    a = ap.parse_args()
    try:
        import numpy  # noqa: F401
        import allantools  # noqa: F401
    except ImportError as e:
        sys.exit(f"bench_allan.py: {e.name} is missing: install it with `pip install allantools` "
                 "(in a virtual environment if you prefer); nothing is installed here")
    if not os.path.exists(a.ptsa):
        sys.exit(f"bench_allan.py: {a.ptsa} is missing: `cargo build --release -p ptsa-host-sim`")
    rnd = random.Random(1)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "r.csv")
        with open(path, "w") as f:
            f.write("time_s,reading\n")
            f.writelines(f"{i / 100:.2f},{rnd.gauss(0.0, 1e-3):.9f}\n" for i in range(a.samples))
        times = {"ptsa": [], "allantools": []}
        work = []
        outputs = {}
        cmds = {
            "ptsa": [a.ptsa, "--instrument", "mems", "noise", "--readings", path, "--unit", "g",
                     "--json"],
            "allantools": [sys.executable, "-c", ALLANTOOLS, path],
        }
        for _ in range(a.runs):
            for name, cmd in cmds.items():
                t0 = time.perf_counter()
                out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
                times[name].append(time.perf_counter() - t0)
                outputs[name] = json.loads(out)
                if name == "allantools":
                    work.append(outputs[name]["work_s"])
    p, q = outputs["ptsa"], outputs["allantools"]
    g = 980.665  # the mems class's gravity: ptsa reports cm/s²
    worst = 0.0
    for pt in p["points"]:
        for tau, adev in zip(q["tau"], q["adev"]):
            if abs(tau - pt["tau_s"]) < 1e-9 * tau:
                worst = max(worst, abs(pt["adev_cm_s2"] / g / adev - 1))
        for tau, mdev in zip(q["tau_m"], q["mdev"]):
            if abs(tau - pt["tau_s"]) < 1e-9 * tau and pt.get("mdev_cm_s2") is not None:
                worst = max(worst, abs(pt["mdev_cm_s2"] / g / mdev - 1))
    mp, mw = statistics.median(times["ptsa"]), statistics.median(work)
    ma = statistics.median(times["allantools"])
    runs = lambda v: ", ".join(f"{t:.3f}" for t in v)  # noqa: E731
    print(f"{a.samples} readings, {a.runs} runs each, alternated:")
    print(f"  ptsa, whole process           median {mp:.3f} s  ({runs(times['ptsa'])})")
    print(f"  allantools, whole process     median {ma:.3f} s  ({runs(times['allantools'])})")
    print(f"  allantools, file to deviations median {mw:.3f} s  ({runs(work)})")
    print(f"  allantools / ptsa = {mw / mp:.2f} on the work alone, {ma / mp:.2f} whole; "
          f"deviations agree to {worst:.1e} (relative)")
    if mw / mp < a.min_ratio:
        sys.exit(f"bench_allan.py: the ratio {mw / mp:.2f} is below --min-ratio {a.min_ratio}")


if __name__ == "__main__":
    main()
