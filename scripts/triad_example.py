#!/usr/bin/env python3
"""A synthetic triad file (docs/method/discovery.md, "A triad"): three accelerometers on one block.

    python3 scripts/triad_example.py PLACEMENT N OUT

PLACEMENT `fixture`: the positions are exactly their nominal orientations; `hand`: each is
turned from nominal by 0.5-1 degree about a random axis (a block placed by hand); `stream`:
the hand-placed positions as one raw stream at 100 Hz (`time_s` and the three readings, no
orientation): 15 s at rest in the first, then each next reached by a 1.5 s turn (the angle's
share (1 - cos(pi t))/2, a push of up to 60 cm/s² along a random direction times
sin(2 pi t)) and held 2-4 s, noise 1 cm/s² per sample. N: 24
(the 24 turns of the cube applied to (1, 2, 3)/sqrt(14)) or 37 (those, the 12 edge
directions and the +z face). The triad: bias (12, -8, 30) cm/s², scale-factor changes
(+10000, -5000, +2000) ppm, misalignments Gamma (rad, row = the axis, a = (I + Gamma) f)
[[0, 0, 0], [0.004, 0, 0], [-0.002, 0.003, 0]] (lower triangular: the triad's frame is the
block's, so the truth reads the same with either --orientation), no K_2, local gravity
980.4 cm/s² (the shipped instrument file's), Gaussian noise 0.1 cm/s² stated in
`sigma_cm_s2`, seeded (`random.seed(1)`): the same file on every machine.
"""
import math
import random
import sys

G = 980.4
BIAS = [12.0, -8.0, 30.0]
SF = [0.01, -0.005, 0.002]
GAMMA = [[0.0, 0.0, 0.0], [0.004, 0.0, 0.0], [-0.002, 0.003, 0.0]]
SIGMA = 0.1


def design(n):
    s = 1 / math.sqrt(14)
    base = [1, 2, 3]
    perms = [([0, 1, 2], 1), ([1, 2, 0], 1), ([2, 0, 1], 1), ([1, 0, 2], -1), ([0, 2, 1], -1), ([2, 1, 0], -1)]
    dirs = []
    for p, parity in perms:
        for signs in range(8):
            sg = [-1 if (signs >> b) & 1 else 1 for b in range(3)]
            if sg[0] * sg[1] * sg[2] * parity > 0:
                dirs.append([sg[r] * base[p[r]] * s for r in range(3)])
    if n == 37:
        r2 = 1 / math.sqrt(2)
        for j, k in [(0, 1), (1, 2), (0, 2)]:
            for a, b in [(1, 1), (1, -1), (-1, 1), (-1, -1)]:
                v = [0.0, 0.0, 0.0]
                v[j], v[k] = a * r2, b * r2
                dirs.append(v)
        dirs.append([0.0, 0.0, 1.0])
    return dirs


def turned(axis, angle, v):
    c, s = math.cos(angle), math.sin(angle)
    d = sum(axis[i] * v[i] for i in range(3))
    cr = [axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2], axis[0] * v[1] - axis[1] * v[0]]
    return [v[i] * c + cr[i] * s + axis[i] * d * (1 - c) for i in range(3)]


def reading(f, noise):
    u = []
    for j in range(3):
        a = f[j] + sum(GAMMA[j][k] * f[k] for k in range(3))
        u.append(BIAS[j] + (1 + SF[j]) * a + random.gauss(0, noise))
    return u


def hand_placed(nom):
    z = random.uniform(-1, 1)
    phi = random.uniform(0, 2 * math.pi)
    rho = math.sqrt(1 - z * z)
    return turned([rho * math.cos(phi), rho * math.sin(phi), z], math.radians(random.uniform(0.5, 1.0)), nom)


def stream(n, out):
    rate, noise = 100.0, 1.0
    dirs = [hand_placed(d) for d in design(n)]
    rows = []

    def sample(f):
        u = reading(f, noise)
        rows.append(f"{len(rows) / rate:.2f},{u[0]:.4f},{u[1]:.4f},{u[2]:.4f}")

    def hold(v, secs):
        for _ in range(round(secs * rate)):
            sample([G * x for x in v])

    hold(dirs[0], 15.0)
    for a, b in zip(dirs, dirs[1:]):
        c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        sn = math.sqrt(sum(x * x for x in c))
        angle = math.atan2(sn, sum(a[i] * b[i] for i in range(3)))
        axis = [x / sn for x in c]
        z, phi = random.uniform(-1, 1), random.uniform(0, 2 * math.pi)
        amp = random.uniform(0, 60.0)
        push = [amp * math.sqrt(1 - z * z) * math.cos(phi), amp * math.sqrt(1 - z * z) * math.sin(phi), amp * z]
        m = round(1.5 * rate)
        for i in range(m):
            t = (i + 0.5) / m
            v = turned(axis, 0.5 * (1 - math.cos(math.pi * t)) * angle, a)
            p = math.sin(2 * math.pi * t)
            sample([G * v[j] + push[j] * p for j in range(3)])
        hold(b, random.uniform(2.0, 4.0))
    with open(out, "w") as fh:
        fh.write(f"# a synthetic {n}-position triad turned by hand, one raw stream at 100 Hz: scripts/triad_example.py\n")
        fh.write("time_s,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n")
        fh.write("\n".join(rows) + "\n")


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("fixture", "hand", "stream") or sys.argv[2] not in ("24", "37"):
        sys.exit(__doc__)
    hand, n, out = sys.argv[1] == "hand", int(sys.argv[2]), sys.argv[3]
    random.seed(1)
    if sys.argv[1] == "stream":
        stream(n, out)
        return
    lines = [
        f"# a synthetic {n}-position triad, {'placed by hand (0.5-1 degree off)' if hand else 'on a precision fixture'}: scripts/triad_example.py",
        "label,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2",
    ]
    for i, nom in enumerate(design(n)):
        v = hand_placed(nom) if hand else nom
        u = reading([G * x for x in v], SIGMA)
        lines.append(f"p{i + 1},{nom[0]:.9f},{nom[1]:.9f},{nom[2]:.9f},{u[0]:.4f},{u[1]:.4f},{u[2]:.4f},{SIGMA}")
    with open(out, "w") as fh:
        fh.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
