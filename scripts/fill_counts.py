#!/usr/bin/env python3
"""Fill the pulses and ticks of a `ptsa plan ... --count-columns` design for a synthetic instrument.

A stand-in for the lab: each position's counts over a gate, written from IEEE Std 1293's
model equation of a pendulous accelerometer with the truth given on the command line,

    E/K_1 = K_0 + a_i + K_2*a_i^2 + delta_o*a_p - delta_p*a_o      (a in g, E in pulse/s)
    K_1   = (1 + k1_ppm*1e-6) * f_clk * g / SF                       ((pulse/s)/g)

and a forced-binary loop's counts over a gate of T clock ticks: 2P - T = E*T/f_clk net
pulses, plus the charge the loop holds at each end of the gate (uniform over one pulse,
independent), rounded to a whole pulse, plus the instrument's own white noise. Nothing of
ptsa is used: the clock, local gravity and nominal SF are the shipped instrument file's
(data/kearfott-2401.toml) unless given.

    python3 scripts/fill_counts.py PLAN.csv FILLED.csv [--k0-ug 19500] [--k1-ppm -150]
        [--delta-o-urad 120] [--delta-p-urad -80] [--k2-ug-g2 30] [--gate-s 60]
        [--noise-ug 5] [--seed 1]

FILLED.csv is not replaced if it exists (remove it first).
"""

import argparse
import csv
import io
import math
import os
import random
import sys


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("plan", help="a design written by `ptsa plan ... --count-columns`")
    ap.add_argument("out", help="the filled design (not replaced if it exists)")
    ap.add_argument("--k0-ug", type=float, default=19500.0, help="bias K_0, µg")
    ap.add_argument("--k1-ppm", type=float, default=-150.0,
                    help="scale factor's change from nominal, ppm")
    ap.add_argument("--delta-o-urad", type=float, default=120.0,
                    help="δ_o, IA toward PA, µrad")
    ap.add_argument("--delta-p-urad", type=float, default=-80.0,
                    help="δ_p, IA toward OA, µrad (enters as −δ_p·a_o)")
    ap.add_argument("--k2-ug-g2", type=float, default=30.0, help="K_2, µg/g²")
    ap.add_argument("--gate-s", type=float, default=60.0, help="each position's gate, s")
    ap.add_argument("--noise-ug", type=float, default=5.0,
                    help="the instrument's white noise over one gate, µg (1 σ)")
    ap.add_argument("--seed", type=int, default=1, help="random seed")
    ap.add_argument("--clock-hz", type=float, default=64000.0)
    ap.add_argument("--g-cm-s2", type=float, default=980.4, help="local gravity, cm/s²")
    ap.add_argument("--sf-cm-s2", type=float, default=21121.1,
                    help="nominal full scale SF, cm/s²")
    a = ap.parse_args()
    if os.path.exists(a.out):
        print(f"fill_counts.py: {a.out} exists; expected a new file (remove it first)",
              file=sys.stderr)
        return 1
    rnd = random.Random(a.seed)
    k1 = (1 + a.k1_ppm * 1e-6) * a.clock_hz * a.g_cm_s2 / a.sf_cm_s2
    ticks = round(a.gate_s * a.clock_hz)
    with open(a.plan, encoding="utf-8") as f:
        lines = f.read().splitlines()
    comments = [l for l in lines if l.startswith("#")]
    rows = list(csv.DictReader(l for l in lines if not l.startswith("#")))
    if not rows or "pulses" not in rows[0] or "ticks" not in rows[0]:
        print(f"fill_counts.py: {a.plan} has no pulses and ticks columns; expected a design "
              "written by `ptsa plan ... --count-columns`", file=sys.stderr)
        return 1
    buf = io.StringIO()
    buf.write("\n".join(comments) + "\n" if comments else "")
    buf.write(f"# Counts filled by scripts/fill_counts.py: K_0 {a.k0_ug} µg, K_1 {a.k1_ppm} ppm, "
              f"δ_o {a.delta_o_urad} µrad, δ_p {a.delta_p_urad} µrad, K_2 {a.k2_ug_g2} µg/g², "
              f"gate {a.gate_s} s, noise {a.noise_ug} µg, seed {a.seed}\n")
    w = csv.DictWriter(buf, fieldnames=list(rows[0].keys()), lineterminator="\n")
    w.writeheader()
    for r in rows:
        ai, ap_, ao = (float(r.get(k) or 0) for k in ("g_ia", "g_pa", "g_oa"))
        e_over_k1 = (a.k0_ug * 1e-6 + ai + a.k2_ug_g2 * 1e-6 * ai * ai
                     + a.delta_o_urad * 1e-6 * ap_ - a.delta_p_urad * 1e-6 * ao
                     + rnd.gauss(0.0, a.noise_ug * 1e-6))
        net = k1 * e_over_k1 * ticks / a.clock_hz        # 2P − T, pulses
        carry = rnd.random() - rnd.random()               # the two ends of the gate
        r["pulses"] = str(int(math.floor((ticks + net) / 2 + carry + 0.5)))
        r["ticks"] = str(ticks)
        w.writerow(r)
    with open(a.out, "x", encoding="utf-8") as f:
        f.write(buf.getvalue())
    print(f"wrote {a.out} ({len(rows)} rows)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
