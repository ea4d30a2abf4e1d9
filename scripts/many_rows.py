#!/usr/bin/env python3
"""A synthetic case-frame file of N measured rows, for measuring `ptsa discover` on many rows.

    python3 scripts/many_rows.py KIND N OUT [--ptsa PATH]

KIND `shaker`: the two-axis oscillator's plan (`ptsa plan shaker --phases min(360, N/4)`,
difference rows at 10 Hz) read by the simulator with a vibropendulosity of 2e-6 s²/cm, plus
0.1 cm/s² of Gaussian noise. KIND `tumble`: a tumble about OA (`ptsa plan tumble
--positions min(360, N)`) with a bias change of 2.0 cm/s², plus 0.05 cm/s² of noise. KIND
`warm`: the same tumble with no effect, its rows a minute apart in `time_s` from power-on,
a turn-on transient 0.5·e^(−t/288 s) cm/s² less its mean over the rows added, plus 0.02
cm/s² of noise. The
plan's rows are repeated (labels ` rep k`) until there are N; `sigma_cm_s2` states the noise.
The values come from `ptsa predict --json` (the closed loop); the noise is seeded
(`random.seed(1)`), so the file is the same on every machine. With N = 1000 and `shaker` it
is the 1000-row file of docs/method/discovery.md, "Speed", byte for byte.
"""
import argparse
import csv
import json
import math
import os
import random
import subprocess
import sys
import tempfile

TRUTH = {
    "shaker": ({"effects": [{"name": "vibropendulosity", "coefficients": {"k_ip_s2_cm": 2e-6}}]}, 0.1),
    "tumble": ({"effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 2.0}}]}, 0.05),
    "warm": ({"effects": []}, 0.02),
}

# The warm-up of KIND `warm`: amplitude (cm/s²), time constant (s), seconds between rows.
WARM = (0.5, 288.0, 60.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=sorted(TRUTH))
    ap.add_argument("n", type=int, help="rows (1 or more)")
    ap.add_argument("out", help="the case-frame file to write (refused if it exists)")
    ap.add_argument("--ptsa", default="target/release/ptsa", help="the ptsa executable")
    a = ap.parse_args()
    if a.n < 1:
        sys.exit("error: N must be 1 or more")
    if os.path.exists(a.out):
        sys.exit(f"error: {a.out} exists; remove it first")
    truth, sigma = TRUTH[a.kind]
    with tempfile.TemporaryDirectory() as tmp:
        plan = os.path.join(tmp, "plan.csv")
        if a.kind == "shaker":
            args = ["plan", "shaker", "--phases", str(min(360, max(2, a.n // 4)))]
        else:
            args = ["plan", "tumble", "--positions", str(min(360, max(2, a.n)))]
        subprocess.run([a.ptsa, *args, "--out", plan], check=True)
        rows = list(csv.reader(l for l in open(plan) if not l.startswith("#")))
        head, body = rows[0], rows[1:]
        label = head.index("label")
        every, k = [], 0
        while len(every) < a.n:
            for r in body[: a.n - len(every)]:
                r2 = list(r)
                if k:
                    r2[label] = f"{r[label]} rep {k}"
                every.append(r2)
            k += 1
        with open(plan, "w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(head)
            w.writerows(every)
        effects = os.path.join(tmp, "truth.json")
        json.dump(truth, open(effects, "w"))
        pred = subprocess.run(
            [a.ptsa, "predict", "--data", plan, "--effects", effects, "--json", "--force"],
            check=True,
            capture_output=True,
        ).stdout
    values = [r["predicted_cm_s2"] for r in json.loads(pred)["rows"]]
    timed = a.kind == "warm"
    if timed:
        amp, tau, step = WARM
        warm = [amp * math.exp(-step * k / tau) for k in range(len(values))]
        mean = sum(warm) / len(warm)
        values = [y + t - mean for y, t in zip(values, warm)]
    random.seed(1)
    m = head.index("measured_cm_s2")
    part = a.out + ".part"
    with open(part, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(head + ["sigma_cm_s2"] + (["time_s"] if timed else []))
        for k, (r, y) in enumerate(zip(every, values)):
            r[m] = repr(y + random.gauss(0, sigma))
            w.writerow(r + [sigma] + ([WARM[2] * k] if timed else []))
    os.replace(part, a.out)
    print(f"wrote {a.out} ({a.n} rows)", file=sys.stderr)


if __name__ == "__main__":
    main()
