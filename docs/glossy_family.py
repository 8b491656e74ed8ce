"""The glossy split sum with other F0 functions, fitted outside furnace.

Fits E ~ sum_a phi_a(F0) P_a(r, t) / Q(r, t) on a glossy model's committed fitting points (the
128^3 table's 32^3 graded nodes and its 8 192 exact training points) and measures it at the
table's 26 112 off-grid check points, as a sweep does. t = slayer:r:k (the root-layer variable
of `fit::data::InputTransform::RootLayer`), P_a and Q of total degree 3 in (r, t), Q's constant
term 1 (39 coefficients). Least squares first (Levenberg-Marquardt from the polynomial, Q held
above 0.02 on a 48 x 48 grid of the (r, t) square by a penalty), then an L_p polish: the
sum of |e_i|^p minimised for p = 4, 8, 16, 32 in turn, each from the last.

The phi_a: `root` {1, F0^(1/4), F0^(1/2)} (furnace's `split:f0:2:3/3` in F0^(1/4)), `log`
{1, F0, ln F0}, `power:<p>` {1, F0^p, F0^(2p)}. An optional fourth argument E widens the layer
as s = k r^E (furnace's `slayer:r:k`: E = 2). Needs numpy and scipy; reads
data/<model>/128x128x128.{f64,train-v1-8192.json,check-v1.json} (made by `furnace run`).
About 3 minutes per run.

    python3 docs/glossy_family.py ggx-glossy log 0.5
    python3 docs/glossy_family.py ggx-glossy root 3 3
"""
import json
import sys

import numpy as np
from scipy.optimize import least_squares

model, family, k = sys.argv[1], sys.argv[2], float(sys.argv[3])
# the power of r in the layer's width s = k r^e (furnace's `slayer:r:k`: e = 2)
e_r = float(sys.argv[4]) if len(sys.argv) > 4 else 2.0
base = f"data/{model}/128x128x128"
lo, hi = 0.0125, 0.25
E = np.fromfile(base + ".f64", "<f8")[: 128**3].reshape(128, 128, 128)
axes = [np.linspace(lo, hi, 128), np.linspace(0, 1, 128), np.linspace(0, 1, 128)]


def graded(p):
    return np.round(127 * (np.arange(32) / 31) ** p).astype(int)


I, J, L = np.meshgrid(graded(1), graded(1.5), graded(2), indexing="ij")
X = np.stack([axes[0][I].ravel(), axes[1][J].ravel(), axes[2][L].ravel()], 1)
Y = E[I, J, L].ravel()
train = json.load(open(base + ".train-v1-8192.json"))
X = np.vstack([X, np.array(train["coords"]).reshape(-1, 3)])
Y = np.concatenate([Y, train["values"]])
check = json.load(open(base + ".check-v1.json"))
Xc, Yc = np.array(check["coords"]).reshape(-1, 3), np.array(check["values"])


def phi(f0):
    if family == "root":
        q = (f0**0.25 - lo**0.25) / (hi**0.25 - lo**0.25)
        return [np.ones_like(f0), q, q * q]
    if family == "log":
        return [np.ones_like(f0), (f0 - lo) / (hi - lo), np.log(f0 / lo) / np.log(hi / lo)]
    if family.startswith("power:"):
        e = float(family[6:])
        q = (f0**e - lo**e) / (hi**e - lo**e)
        return [np.ones_like(f0), q, q * q]
    sys.exit(f"unknown family {family}: write root, log or power:<p>")


def monomials(r, t):
    return np.stack([r**i * t ** (n - i) for n in range(4) for i in range(n + 1)], 1)


def root_layer(r, mu):
    s = k * r**e_r
    return (np.sqrt(mu + s) - np.sqrt(s)) / (np.sqrt(1 + s) - np.sqrt(s))


def design(X):
    f0, r, mu = X.T
    M = monomials(r, root_layer(r, mu))
    return np.hstack([p[:, None] * M for p in phi(f0)]), M[:, 1:]


N, D = design(X)
Nc, Dc = design(Xc)
n = N.shape[1]
gr, gt = np.meshgrid(np.linspace(0, 1, 48), np.linspace(0, 1, 48))
DG = monomials(gr.ravel(), gt.ravel())[:, 1:]


def residuals(c):
    return N @ c[:n] / (1 + D @ c[n:]) - Y


def penalty(c):
    return 1e2 * np.maximum(0, 0.02 - (1 + DG @ c[n:]))


def report(tag, c):
    e = np.abs(Nc @ c[:n] / (1 + Dc @ c[n:]) - Yc)
    print(f"{model} {family} k={k} e={e_r} {tag}: off grid max {e.max():.3e} MAE {e.mean():.3e}", flush=True)


c = np.zeros(n + D.shape[1])
c[:n] = np.linalg.lstsq(N, Y, rcond=None)[0]
c = least_squares(lambda c: np.concatenate([residuals(c), penalty(c)]), c, method="lm", max_nfev=6000).x
report("least squares", c)
for p in [4, 8, 16, 32]:
    scale = np.abs(residuals(c)).max()

    def lp(c):
        e = residuals(c) / scale
        return np.concatenate([np.sign(e) * np.abs(e) ** (p / 2), penalty(c)])

    c = least_squares(lp, c, method="lm", max_nfev=3000).x
    report(f"p = {p}", c)
