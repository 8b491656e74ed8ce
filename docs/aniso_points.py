"""Point sets for fitting and checking the anisotropic conductor's albedo (docs/anisotropy.md, "Fits").

    python3 docs/aniso_points.py train 20 8 24 8 > train.in.csv   # grid, layer-resolving
    python3 docs/aniso_points.py check > check.in.csv              # 10 000 independent points
    python3 docs/aniso_points.py compare check.csv fit.csv         # max and mean |fit - exact|
    python3 docs/aniso_points.py svd grid.csv 32 12 32 12          # separability of a train grid

Columns r, aniso, mu, phi (OpenPBR's r and aniso; mu = cos(theta_o); phi the azimuth from the
tangent), to be evaluated with `furnace eval --model ggx-conductor-aniso`.

The grid is uniform in the fit variables, not in (mu, phi): r^2, aniso, sin^2(phi), and
t = sqrt(L) with L = (mu(1 + k a_o))/(mu + k a_o), k = 2, the projected-layer variable
`player:r:aniso:phi:2:2` (a_o = a_t sqrt(1 - (1 - (1 - aniso)^2) sin^2 phi), the projected roughness
of Heitz 2014, eq. 80; a_t = r^2 sqrt(2/(1 + (1 - aniso)^2), OpenPBR), so mu = L k a_o/(1 + k a_o - L).
A grid uniform in mu leaves the grazing layer mu < a_o unsampled at small r.
The check set: 6 000 random points uniform in the same variables (seed 1) and 4 000 uniform in
(r, aniso, mu, phi) (seed 2).
"""
import sys

import numpy as np


def mu_of_t(t, r, aniso, phi, k=2.0):
    a_t = r * r * np.sqrt(2.0 / (1.0 + (1.0 - aniso) ** 2))
    a_o = a_t * np.sqrt(1.0 - (1.0 - (1.0 - aniso) ** 2) * np.sin(phi) ** 2)
    s = k * a_o
    big_l = t * t
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = np.where(s > 0, big_l * s / np.maximum(1.0 + s - big_l, 1e-300), t)
    return np.clip(mu, 0.0, 1.0)


def grid(nr, na, nm, nphi):
    rs = np.sqrt(np.linspace(0, 1, nr))
    anisos = np.linspace(0, 0.95, na)
    ts = np.linspace(0, 1, nm)
    phis = np.arcsin(np.sqrt(np.linspace(0, 1, nphi)))
    r, a, t, p = [x.ravel() for x in np.meshgrid(rs, anisos, ts, phis, indexing="ij")]
    return r, a, mu_of_t(t, r, a, p), p


def check():
    g = np.random.default_rng(1)
    n = 6000
    r = np.sqrt(g.random(n))
    a = 0.95 * g.random(n)
    p = np.arcsin(np.sqrt(g.random(n)))
    t = g.random(n)
    layer = (r, a, mu_of_t(t, r, a, p), p)
    g = np.random.default_rng(2)
    n = 4000
    box = (g.random(n), 0.95 * g.random(n), g.random(n), g.random(n) * np.pi / 2)
    return tuple(np.concatenate([x, y]) for x, y in zip(layer, box))


def write(points):
    out = sys.stdout
    out.write("r,aniso,mu,phi\n")
    for p in zip(*points):
        out.write(",".join("%.17g" % v for v in p) + "\n")


def compare(exact_csv, fit_csv):
    exact = np.genfromtxt(exact_csv, delimiter=",", names=True)
    fit = np.genfromtxt(fit_csv, delimiter=",", names=True)
    e = np.abs(exact["E"] - fit[fit.dtype.names[-1]])
    i = int(np.argmax(e))
    at = ", ".join("%s = %.4g" % (k, exact[k][i]) for k in ("r", "aniso", "mu", "phi"))
    print("max %.3e at %s; mean %.3e; over %d points" % (e.max(), at, e.mean(), len(e)))


def svd(grid_csv, shape):
    """Largest residual of the best rank-K approximation (truncated SVD, Eckart-Young in the
    Frobenius norm) of the train grid's E, reshaped as a matrix over two groups of the fit
    variables (r^2, aniso, t, sin^2 phi): what a low-rank form with exact factors could reach."""
    e = np.genfromtxt(grid_csv, delimiter=",", names=True)["E"].reshape(shape)
    names = ("r", "aniso", "t", "phi")
    groups = (((1, 3), (0, 2)), ((1,), (0, 2, 3)), ((3,), (0, 1, 2)), ((0,), (1, 2, 3)), ((2,), (0, 1, 3)))
    for rows, cols in groups:
        m = e.transpose(rows + cols).reshape(int(np.prod([shape[i] for i in rows])), -1)
        u, s, vt = np.linalg.svd(m, full_matrices=False)
        res = []
        for k in range(1, 9):
            res.append("%.1e" % np.abs(m - (u[:, :k] * s[:k]) @ vt[:k]).max())
        label = "(%s) x (%s)" % (", ".join(names[i] for i in rows), ", ".join(names[i] for i in cols))
        print("%-24s rank 1..8: %s" % (label, " ".join(res)))


if __name__ == "__main__":
    if sys.argv[1:2] == ["train"]:
        write(grid(*[int(v) for v in sys.argv[2:6]]))
    elif sys.argv[1:2] == ["check"]:
        write(check())
    elif sys.argv[1:2] == ["compare"]:
        compare(sys.argv[2], sys.argv[3])
    elif sys.argv[1:2] == ["svd"]:
        svd(sys.argv[2], tuple(int(v) for v in sys.argv[3:7]))
    else:
        sys.exit("usage: aniso_points.py train NR NA NMU NPHI | check | compare EXACT FIT | svd GRID NR NA NMU NPHI")
