#!/usr/bin/env python3
"""Why `ptsa noise --identify` widens its intervals: the fit's weights in a model small
enough to draw thousands of times.

    python3 scripts/interval_model.py [--trials 2000] [--rho 0.6] [--replicas 24] [--seed 1]

The model is the identification's, linearised: 12 octave points of ln AVAR whose errors are
Gaussian, correlated `rho^|a-b|` between octaves a and b and with standard deviations rising
1.35 times an octave; two parameters, one that moves every point (a white noise) and a
nuisance that moves only the longest three (a walk). Each trial draws `--replicas` records
to estimate the covariance (its correlations shrunk halfway to none, as `noise/identify.rs`
does with `SHRINK`), weights the fit by the inverse of that estimate, draws the "measured"
points independently, fits both parameters by weighted least squares and asks whether the
first parameter's 95 % interval holds its true value (0), for:

* `profile`:     Delta chi2 <= 3.84, the weights taken as the truth;
* `birge`:       the same, 3.84 times the squared Birge ratio when above 1 (what ptsa did);
* `sandwich`:    3.84 times the sandwich ratio, the covariance from a second, independent set
                 of replicas;
* `sandwich_t`:  as `sandwich`, Student's t with replicas - 1 degrees of freedom for 1.96,
                 and the Birge ratio (what ptsa does now);
* `true_w`:      the weights the true inverse covariance (the reference: 95 %).

Pure Python, no packages; the figures of docs/method/noise.md come from `--trials 2000` at
`--rho` 0.3, 0.6 and 0.9, `--seed 1`.
"""
import argparse
import math
import random

P = 12
# Student's t, two-sided 5 %, for replicas - 1 degrees of freedom (printed tables)
T2 = {24: 2.068658 ** 2, 48: 2.011741 ** 2}
CHI2_1 = 3.841459


def cholesky(a):
    n = len(a)
    low = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = a[i][j] - sum(low[i][k] * low[j][k] for k in range(j))
            low[i][j] = math.sqrt(s) if i == j else s / low[j][j]
    return low


def inverse(a):
    n = len(a)
    m = [row[:] + [1.0 if i == j else 0.0 for j in range(n)] for i, row in enumerate(a)]
    for c in range(n):
        piv = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[piv] = m[piv], m[c]
        f = m[c][c]
        m[c] = [x / f for x in m[c]]
        for r in range(n):
            if r != c and m[r][c] != 0.0:
                g = m[r][c]
                m[r] = [x - g * y for x, y in zip(m[r], m[c])]
    return [row[n:] for row in m]


def covariance(rows):
    n = len(rows)
    mean = [sum(r[k] for r in rows) / n for k in range(P)]
    return [[sum((r[a] - mean[a]) * (r[b] - mean[b]) for r in rows) / (n - 1)
             for b in range(P)] for a in range(P)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=2000)
    ap.add_argument("--rho", type=float, default=0.6)
    ap.add_argument("--replicas", type=int, default=24)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    if a.replicas not in T2:
        ap.error(f"--replicas: {sorted(T2)} (the t points this script holds), not {a.replicas}")
    rng = random.Random(a.seed)
    sd = [0.05 * 1.35 ** k for k in range(P)]
    sigma = [[sd[i] * sd[j] * a.rho ** abs(i - j) for j in range(P)] for i in range(P)]
    low = cholesky(sigma)
    cols = [[min(1.0, 0.15 * k) for k in range(P)], [0.0] * (P - 3) + [0.25, 0.5, 0.75]]

    def draw():
        z = [rng.gauss(0.0, 1.0) for _ in range(P)]
        return [sum(low[i][k] * z[k] for k in range(i + 1)) for i in range(P)]

    def fit(r, w):
        wx = [[sum(w[i][j] * cols[c][j] for j in range(P)) for c in range(2)] for i in range(P)]
        a_inv = inverse([[sum(cols[c][i] * wx[i][d] for i in range(P)) for d in range(2)]
                         for c in range(2)])
        rhs = [sum(wx[i][c] * r[i] for i in range(P)) for c in range(2)]
        beta = [sum(a_inv[c][d] * rhs[d] for d in range(2)) for c in range(2)]
        res = [r[i] - sum(cols[c][i] * beta[c] for c in range(2)) for i in range(P)]
        chi2 = sum(res[i] * w[i][j] * res[j] for i in range(P) for j in range(P))
        return beta, a_inv, wx, chi2

    def sandwich(a_inv, wx, cov):
        meat = [[sum(wx[i][c] * cov[i][j] * wx[j][d] for i in range(P) for j in range(P))
                 for d in range(2)] for c in range(2)]
        v = sum(a_inv[0][c] * meat[c][d] * a_inv[d][0] for c in range(2) for d in range(2))
        return v / a_inv[0][0]

    held = dict(profile=0, birge=0, sandwich=0, sandwich_t=0, true_w=0)
    true_w = inverse(sigma)
    for _ in range(a.trials):
        est = covariance([draw() for _ in range(a.replicas)])
        shrunk = [[est[i][j] * (1.0 if i == j else 0.5) for j in range(P)] for i in range(P)]
        w = inverse(shrunk)
        r = draw()
        beta, a_inv, wx, chi2 = fit(r, w)
        z2 = beta[0] ** 2 / a_inv[0][0]
        b2 = max(1.0, chi2 / (P - 2))
        check = covariance([draw() for _ in range(a.replicas)])
        s = sandwich(a_inv, wx, check)
        held["profile"] += z2 <= CHI2_1
        held["birge"] += z2 <= CHI2_1 * b2
        held["sandwich"] += z2 <= CHI2_1 * s
        held["sandwich_t"] += z2 <= T2[a.replicas] * s * b2
        bt, at, _, _ = fit(r, true_w)
        held["true_w"] += bt[0] ** 2 / at[0][0] <= CHI2_1
    print(f"rho {a.rho}, {a.replicas} replicas, {a.trials} trials: intervals holding the value")
    for k, v in held.items():
        print(f"  {k:11s} {v / a.trials:6.1%}")


if __name__ == "__main__":
    main()
