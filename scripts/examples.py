#!/usr/bin/env python3
"""Write the README's example files (data/examples/), all synthetic, all seeded.

    python3 scripts/examples.py OUTDIR

OUTDIR must not exist yet (nothing is replaced). From the shipped designs in
data/examples/ (written by `ptsa plan`, checked by a test to be what it writes):

* tumble-counts.csv: the 24-point counts tumble filled by scripts/fill_counts.py (its
  default truth: K_0 19 500 µg, K_1 150 ppm below nominal, δ_o 120 µrad, K_2 30 µg/g²,
  5 µg of noise, seed 1);
* check-counts.csv: the 8-point counts tumble filled with the same truth, seed 2, as
  the record `ptsa correct` is shown on;
* static-readings.csv: a MEMS part's static record in g at 10 Hz for 1200 s: a bias of
  12.5 mg, white noise of 100 µg/√Hz (N) and a bias random walk of 10 µg/s/√Hz (K),
  seed 3 (below);
* triad-stream.csv: a triad turned by hand through 24 positions, one raw stream at
  100 Hz (scripts/triad_example.py stream 24).

Nothing of ptsa is used to fill them: each truth is written from its equation here or in
the script named.
"""
import math
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PLANS = os.path.join(ROOT, "data", "examples")

RATE_HZ = 10.0
SECONDS = 1200
BIAS_G = 0.0125
N_G_RT_HZ = 100e-6   # white noise density, g/√Hz: Allan deviation N/√τ
K_G_S_RT_HZ = 10e-6  # bias random walk, g/s/√Hz: Allan deviation K·√(τ/3)


def static_readings(path):
    """White noise N/√dt per sample plus a random walk stepped K·√dt per sample."""
    rnd = random.Random(3)
    dt = 1.0 / RATE_HZ
    walk = 0.0
    lines = [
        "# synthetic: a MEMS accelerometer's static record, reading in g at 10 Hz: "
        f"bias {BIAS_G} g, N = {N_G_RT_HZ:g} g/sqrt(Hz), K = {K_G_S_RT_HZ:g} g/s/sqrt(Hz), "
        "seed 3 (scripts/examples.py)",
        "time_s,reading",
    ]
    for i in range(round(SECONDS * RATE_HZ)):
        walk += rnd.gauss(0.0, K_G_S_RT_HZ * math.sqrt(dt))
        y = BIAS_G + walk + rnd.gauss(0.0, N_G_RT_HZ / math.sqrt(dt))
        lines.append(f"{i * dt:.1f},{y:.7f}")
    with open(path, "x", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def run(*args):
    subprocess.run([sys.executable, *args], check=True, stderr=subprocess.DEVNULL)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    if os.path.exists(out):
        sys.exit(f"examples.py: {out} exists; expected a new folder (nothing is replaced)")
    os.makedirs(out)
    fill = os.path.join(HERE, "fill_counts.py")
    run(fill, os.path.join(PLANS, "tumble-plan.csv"), os.path.join(out, "tumble-counts.csv"))
    run(fill, os.path.join(PLANS, "check-plan.csv"), os.path.join(out, "check-counts.csv"),
        "--seed", "2")
    static_readings(os.path.join(out, "static-readings.csv"))
    run(os.path.join(HERE, "triad_example.py"), "stream", "24",
        os.path.join(out, "triad-stream.csv"))
    print(f"wrote {out}/{{tumble-counts,check-counts,static-readings,triad-stream}}.csv",
          file=sys.stderr)


if __name__ == "__main__":
    main()
