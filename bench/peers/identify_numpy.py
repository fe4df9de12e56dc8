"""The identification pipeline written plainly with numpy, as a speed peer of
`zmp_validation::identify` (bench/benches/identify.rs runs both in the same run).

Reads a zmp-campaign/1 folder; per record: steady state = the data after the first 3 s cut to
whole periods, least-squares sine fit (DC + 3 harmonics) of the excited input and both outputs
at the known frequency plus a few frequency-refinement iterations (parabolic on the summed
residual); then the weighted pendulum fit G_ij = (a_ij + b_ij w^2) H(jw) with H fixed at the
seed's 900/(s^2 + 60 s + 900). Prints {"wall_s": ..., "records": ..., "a11": ...} as JSON.

Usage: python identify_numpy.py CAMPAIGN_DIR
"""

import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

K = 3


def design(t, w):
    cols = [np.ones_like(t)]
    for k in range(1, K + 1):
        cols += [np.sin(k * w * t), np.cos(k * w * t)]
    return np.column_stack(cols)


def fit(t, ys, w):
    a = design(t, w)
    x, res, _, _ = np.linalg.lstsq(a, ys, rcond=None)
    r = ys - a @ x
    return x, (r * r).sum(axis=0)


def analyse(path, meta):
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=None)
    with open(path) as f:
        header = f.readline().strip().split(",")
    col = {n: i for i, n in enumerate(header)}
    t = data[:, col["t"]]
    u = data[:, col["x_cr" if meta["excited"] == "x" else "y_cr"]]
    ys = np.column_stack([u, data[:, col["zmp_x"]], data[:, col["zmp_y"]]])
    w = meta["omega"]
    dt = (t[-1] - t[0]) / (len(t) - 1)
    per = 2 * np.pi / w
    start = int(np.ceil(3.0 / dt))
    n = int(np.floor((len(t) - start) * dt / per) * per / dt)
    t, ys = t[start : start + n], ys[start : start + n]
    ys = ys - ys.mean(axis=0)
    scale = (ys * ys).sum(axis=0)
    # Frequency refinement: parabolic steps on the summed normalised residual.
    delta = 0.1 * 2 * np.pi / (n * dt)
    for _ in range(2):
        c = [(fit(t, ys, w + d * delta)[1] / scale).sum() for d in (-1, 0, 1)]
        curv = c[0] - 2 * c[1] + c[2]
        if curv > 0:
            w = w + np.clip(0.5 * delta * (c[0] - c[2]) / curv, -2 * delta, 2 * delta)
        delta /= 4
    x, rss = fit(t, ys, w)
    p = x[1] + 1j * x[2]
    g = (x[1, 1:] + 1j * x[2, 1:]) / p[0]
    var = rss / (n - 1 - 2 * K)
    sigma = np.sqrt(2 / n * var[1:]) / abs(p[0])
    return w, g, sigma


def main():
    camp = Path(sys.argv[1])
    t0 = time.perf_counter()
    manifest = tomllib.loads((camp / "campaign.toml").read_text())
    rows = []
    for rec in manifest["records"]:
        w, g, s = analyse(camp / rec["file"], rec)
        j = 0 if rec["excited"] == "x" else 1
        for i in range(2):
            rows.append((i, j, w, g[i], s[i]))
    h = lambda w: 900.0 / (900.0 - w * w + 60j * w)
    out = {}
    for i in range(2):
        for j in range(2):
            pts = [r for r in rows if r[0] == i and r[1] == j]
            a_rows, b = [], []
            for _, _, w, g, s in pts:
                hh = h(w)
                for re in (True, False):
                    f = (lambda z: z.real) if re else (lambda z: z.imag)
                    a_rows.append([f(hh) / s, f(hh) * w * w / s])
                    b.append(f(g) / s)
            sol, *_ = np.linalg.lstsq(np.array(a_rows), np.array(b), rcond=None)
            out[f"a{i+1}{j+1}"] = sol[0]
            out[f"b{i+1}{j+1}"] = sol[1]
    wall = time.perf_counter() - t0
    print(json.dumps({"wall_s": wall, "records": len(manifest["records"]), **out}))


if __name__ == "__main__":
    main()
