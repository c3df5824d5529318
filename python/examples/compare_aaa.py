"""ratfit against scipy's AAA on the same 1-D data: error at the samples,
poles inside the domain, the largest value between the samples, bytes and
time. Writes a markdown table (default docs/results/python-aaa.md).

    python python/examples/compare_aaa.py [--data DIR] [--out FILE]

AAA interpolates (no error bound): at its default tolerance it follows the
noise of measured data; at a 2% tolerance it is compared with ratfit's 2%
intervals. Poles count as inside when their real part lies in the domain and
their imaginary part is below 1e-6 of its width (a real pole of r).
"""

import argparse
import os
import pathlib
import time

import numpy as np
import scipy
from scipy.interpolate import AAA

import ratfit

REPO = pathlib.Path(__file__).resolve().parents[2]


def datasets(data_dir):
    x = np.linspace(-1, 1, 2000)
    yield "Runge 1/(1+25x^2), 2000 points", x, 1 / (1 + 25 * x * x)
    rows = np.loadtxt(data_dir / "alta" / "pink-felt-1d.alta", comments="#")
    for c, name in ((1, "red"), (2, "green"), (3, "blue")):
        yield f"MERL pink-felt slice, {name} ({len(rows)} points)", rows[:, 0], rows[:, c]


def real_poles_inside(poles, lo, hi):
    width = hi - lo
    p = np.asarray(poles)
    inside = (p.real >= lo) & (p.real <= hi) & (np.abs(p.imag) <= 1e-6 * width)
    return int(inside.sum())


def ratfit_poles_inside(f):
    lo, hi = f.domain[0][0], f.domain[1][0]
    roots = np.polynomial.chebyshev.chebroots(f.denominator) if f.n_q > 1 else np.array([])
    # Roots in the mapped variable t in [-1, 1].
    x = lo + (roots + 1) * (hi - lo) / 2
    return real_poles_inside(x, lo, hi)


def figures(name, method, r, x, y, poles_inside, nbytes, seconds):
    dense = np.linspace(x.min(), x.max(), 20 * len(x) + 1)
    with np.errstate(all="ignore"):
        at = np.asarray(r(x), dtype=complex).real
        between = np.asarray(r(dense), dtype=complex).real
    rel = np.abs(at / y - 1)
    peak = np.max(np.abs(between)) / np.max(np.abs(y))
    return (name, method, np.max(rel), np.median(rel), poles_inside, peak, nbytes, seconds)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("RATFIT_DATA", REPO.parent / "shared" / "data"))
    parser.add_argument("--out", default=REPO / "docs" / "results" / "python-aaa.md")
    args = parser.parse_args()
    rows = []
    for name, x, y in datasets(pathlib.Path(args.data)):
        t = time.perf_counter()
        f = ratfit.fit(x, y, rel_tol=0.02, max_coeffs=40)
        seconds = time.perf_counter() - t
        rows.append(figures(name, "ratfit, 2% intervals", f, x, y, ratfit_poles_inside(f), f.nbytes, seconds))
        for label, rtol in (("AAA, default rtol", None), ("AAA, rtol 0.02", 0.02)):
            t = time.perf_counter()
            a = AAA(x, y) if rtol is None else AAA(x, y, rtol=rtol)
            seconds = time.perf_counter() - t
            # Support points, values and weights: three f32 numbers each.
            nbytes = 12 * len(a.support_points)
            inside = real_poles_inside(a.poles(), x.min(), x.max())
            rows.append(figures(name, label, a, x, y, inside, nbytes, seconds))
    lines = [
        "# ratfit against scipy's AAA on 1-D data",
        "",
        f"Command: `python python/examples/compare_aaa.py` (scipy {scipy.__version__}, numpy {np.__version__}, "
        f"ratfit {ratfit.__version__}; 2 cores). Max and median relative error at the samples; real poles "
        "inside the domain; the largest |r| on a grid 20x denser than the samples over the data's largest "
        "value (an explosion between samples shows); bytes as f32 (ratfit: coefficients; AAA: support "
        "points, values and weights); fit time of one run (the first AAA call includes its warm-up).",
        "",
        "| data | method | max rel | median rel | poles inside | max between / data max | bytes | time s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, method, mx, med, poles, peak, nbytes, seconds in rows:
        lines.append(
            f"| {name} | {method} | {mx:.2e} | {med:.2e} | {poles} | {peak:.3g} | {nbytes} | {seconds:.3f} |"
        )
    pathlib.Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
