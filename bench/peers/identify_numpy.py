"""The identification pipeline written the way a competent numpy user would, as the speed peer
of `cargo xtask identify` and `zmp_identify` (bench/benches/identify.rs and
bench/benches/commands.rs run both in the same run).

Fair by construction: the CSV records are read by pyarrow's multithreaded C++ reader, the
per-record work runs on a pool of as many threads as we use (`--threads`, default 2: numpy and
pyarrow release the GIL in their kernels), and every fit is vectorised: the design matrix of
all samples at once (harmonics as powers of one complex exponential), normal equations by BLAS (`A.T @ A`, `A.T @ Y`), residuals from the normal
equations. BLAS itself is limited to the same thread count (`OPENBLAS_NUM_THREADS` etc. are set
before numpy is imported).

Per record: steady state = the data after the first 3 s cut to whole periods; least-squares
sine fit (DC + 3 harmonics) of the excited input and both outputs at the known frequency, with
two parabolic frequency refinements on the summed normalised residual; then the weighted
pendulum fit G_ij = (a_ij + b_ij w^2) H(jw) with H fixed at the seed's 900/(s^2 + 60 s + 900).
Prints {"wall_s": ..., "records": ..., "threads": ..., "a11": ...} as JSON; wall_s covers
reading campaign.toml, the records and the fits (interpreter start and imports excluded).

Usage: python identify_numpy.py CAMPAIGN_DIR [--threads N]
"""

import os
import sys

THREADS = 2
if "--threads" in sys.argv:
    THREADS = int(sys.argv[sys.argv.index("--threads") + 1])
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = str(THREADS)

import json  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402
from concurrent.futures import ThreadPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.csv as pacsv  # noqa: E402

K = 3


def fit(t, ys, yy, w):
    """Least squares of ys (n x 3) on DC + K harmonics at w: coefficients and residual sums.
    The harmonics by complex powers of one exponential (one transcendental per sample)."""
    z = np.exp(1j * w * t)
    a = np.empty((len(t), 2 * K + 1))
    a[:, 0] = 1.0
    zk = z
    for k in range(K):
        a[:, 1 + 2 * k] = zk.imag
        a[:, 2 + 2 * k] = zk.real
        if k + 1 < K:
            zk = zk * z
    aty = a.T @ ys
    x = np.linalg.solve(a.T @ a, aty)
    return x, yy - (x * aty).sum(axis=0)


def analyse(table, meta):
    cols = table.column_names
    t = table.column(cols.index("t")).to_numpy()
    u_name = "x_cr" if meta["excited"] == "x" else "y_cr"
    ys = np.column_stack(
        [table.column(cols.index(n)).to_numpy() for n in (u_name, "zmp_x", "zmp_y")]
    )
    w = meta["omega"]
    dt = (t[-1] - t[0]) / (len(t) - 1)
    per = 2 * np.pi / w
    start = int(np.ceil(3.0 / dt))
    n = int(np.floor((len(t) - start) * dt / per) * per / dt)
    t, ys = t[start : start + n], ys[start : start + n]
    ys = ys - ys.mean(axis=0)
    yy = (ys * ys).sum(axis=0)
    # Frequency refinement: parabolic steps on the summed normalised residual.
    delta = 0.1 * 2 * np.pi / (n * dt)
    for _ in range(2):
        c = [(fit(t, ys, yy, w + d * delta)[1] / yy).sum() for d in (-1, 0, 1)]
        curv = c[0] - 2 * c[1] + c[2]
        if curv > 0:
            w = w + np.clip(0.5 * delta * (c[0] - c[2]) / curv, -2 * delta, 2 * delta)
        delta /= 4
    x, rss = fit(t, ys, yy, w)
    p = x[1] + 1j * x[2]
    g = (x[1, 1:] + 1j * x[2, 1:]) / p[0]
    var = rss / (n - 1 - 2 * K)
    sigma = np.sqrt(2 / n * var[1:]) / abs(p[0])
    return w, g, sigma


def read_and_analyse(path, meta):
    opts = pacsv.ConvertOptions(column_types={n: pa.float64() for n in ("t", "x_cr", "y_cr", "zmp_x", "zmp_y")})
    return analyse(pacsv.read_csv(path, convert_options=opts), meta)


def main():
    camp = Path(sys.argv[1])
    pa.set_cpu_count(THREADS)
    pa.set_io_thread_count(THREADS)
    t0 = time.perf_counter()
    manifest = tomllib.loads((camp / "campaign.toml").read_text())
    recs = manifest["records"]
    with ThreadPoolExecutor(max_workers=THREADS) as pool:
        fits = list(pool.map(lambda r: read_and_analyse(camp / r["file"], r), recs))
    rows = []
    for rec, (w, g, s) in zip(recs, fits):
        j = 0 if rec["excited"] == "x" else 1
        for i in range(2):
            rows.append((i, j, w, g[i], s[i]))
    out = {}
    for i in range(2):
        for j in range(2):
            pts = [r for r in rows if r[0] == i and r[1] == j]
            w = np.array([r[2] for r in pts])
            g = np.array([r[3] for r in pts])
            s = np.array([r[4] for r in pts])
            h = 900.0 / (900.0 - w * w + 60j * w)
            a = np.concatenate([np.column_stack([h.real, h.real * w * w]), np.column_stack([h.imag, h.imag * w * w])]) / np.concatenate([s, s])[:, None]
            b = np.concatenate([g.real, g.imag]) / np.concatenate([s, s])
            sol, *_ = np.linalg.lstsq(a, b, rcond=None)
            out[f"a{i+1}{j+1}"] = sol[0]
            out[f"b{i+1}{j+1}"] = sol[1]
    wall = time.perf_counter() - t0
    print(json.dumps({"wall_s": wall, "records": len(recs), "threads": THREADS, **out}))


if __name__ == "__main__":
    main()
