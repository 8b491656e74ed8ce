"""A fresh check set for the fits over (f0, r, mu) or (r, mu), drawn independently of the check
points stored with each fit (docs/fitting.md, "A second, fresh check set").

    python3 docs/fresh_points.py make > pts.csv                 # 20 000 points, seed 20261204
    python3 docs/fresh_points.py make 2d > pts2d.csv            # the same without f0
    furnace eval --model ggx-dielectric --input pts.csv --output truth.csv
    furnace eval --fit fits/ggx-dielectric/best-40.json --input pts.csv --output fit.csv
    python3 docs/fresh_points.py compare truth.csv fit.csv      # max and mean |fit - exact|

The points: F0 uniform in [0.0125, 0.25] (the fits' domain) with (r, mu) uniform on the square
(60 %), in the grazing layer mu <= 3 r^2 (20 %), at low roughness r <= 0.15 (10 %) and on the six
faces of the box (10 %); `2d` drops the f0 column (the same (r, mu), the two F0 faces
included). Standard library only; the same seed gives the same bytes.
"""
import csv
import random
import sys

F0_LO, F0_HI = 0.0125, 0.25


def make(n=20000, seed=20261204, with_f0=True):
    rng = random.Random(seed)
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["f0", "r", "mu"] if with_f0 else ["r", "mu"])
    for _ in range(n):
        f0 = rng.uniform(F0_LO, F0_HI)
        u = rng.random()
        if u < 0.6:
            r, mu = rng.random(), rng.random()
        elif u < 0.8:
            r = rng.random()
            mu = min(1.0, rng.random() * 3.0 * r * r)
        elif u < 0.9:
            r, mu = rng.random() * 0.15, rng.random()
        else:
            face = rng.randrange(6)
            r, mu = rng.random(), rng.random()
            if face == 0:
                f0 = F0_LO
            elif face == 1:
                f0 = F0_HI
            elif face == 2:
                r = 0.0
            elif face == 3:
                r = 1.0
            elif face == 4:
                mu = 0.0
            else:
                mu = 1.0
        row = ["%.17g" % r, "%.17g" % mu]
        out.writerow(["%.17g" % f0] + row if with_f0 else row)


def column(path, name="E"):
    with open(path, newline="") as f:
        return [float(row[name]) for row in csv.DictReader(f)]


def compare(truth, fits):
    t = column(truth)
    for path in fits:
        v = column(path)
        if len(v) != len(t):
            sys.exit("%s has %d rows, %s %d" % (path, len(v), truth, len(t)))
        e = [abs(a - b) for a, b in zip(t, v)]
        print("%s: max %.3e, mean %.3e over %d points" % (path, max(e), sum(e) / len(e), len(e)))


if __name__ == "__main__":
    if len(sys.argv) in (2, 3) and sys.argv[1] == "make" and sys.argv[2:] in ([], ["2d"]):
        make(with_f0=sys.argv[2:] != ["2d"])
    elif len(sys.argv) >= 4 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3:])
    else:
        sys.exit(__doc__)
