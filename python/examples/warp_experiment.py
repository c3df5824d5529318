"""Does a roughness-scaled warp of theta_h save coefficients? The luminance
of each RGL file on the phi_d = pi/2 slice (40 x 40 cells, sqrt-spaced in
theta_h, both elevations below 80 degrees), intervals of +-TOL (floor 1% of
the median), fitted in four coordinates for theta_h: MERL's sqrt warp,
radians, and the roughness warp u = (2/pi) atan2(sin theta_h, a cos theta_h)
with a = alpha (the GGX lobe fitted to the table) and a = 2 alpha, which
gives a GGX peak the same width in u whatever the roughness. Writes a
markdown table (default docs/results/roughness-warp.md).

    python python/examples/warp_experiment.py [--tol 0.2] [--data DIR] [--out FILE]
"""

import argparse
import os
import pathlib
import time

import numpy as np

import ratfit

REPO = pathlib.Path(__file__).resolve().parents[2]
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def slice_directions(theta_h, theta_d, phi_d=np.pi / 2):
    """wi, wo of Rusinkiewicz angles with phi_h = 0."""
    d = np.stack([np.sin(theta_d) * np.cos(phi_d), np.sin(theta_d) * np.sin(phi_d), np.cos(theta_d)], -1)
    c, s = np.cos(theta_h), np.sin(theta_h)

    def rotate(v):
        return np.stack([c * v[:, 0] + s * v[:, 2], v[:, 1], -s * v[:, 0] + c * v[:, 2]], -1)

    return rotate(d), rotate(d * np.array([-1, -1, 1]))


def lobe_alpha(path):
    # A coarse, loose fit only to get the lobe the fit starts from.
    lobe = ratfit.fit_brdf(
        path, dims=2, resolution=(8, 8), rel_tol=0.5, lobe=True, render_check=False,
        max_coeffs=20, max_widenings=10,
    )
    return lobe.report["report"]["lobe"]["alpha"]


def run(path, tol, n=40):
    table = ratfit.read_material(str(path))
    alpha = lobe_alpha(str(path))
    u = (np.arange(n) + 0.5) / n
    th, td = np.meshgrid(u**2 * np.pi / 2, u * np.pi / 2 * 0.95, indexing="ij")
    th, td = th.ravel(), td.ravel()
    wi, wo = slice_directions(th, td)
    keep = (wi[:, 2] > np.cos(np.radians(80))) & (wo[:, 2] > np.cos(np.radians(80)))
    v = table.eval(wi[keep], wo[keep]) @ LUMINANCE
    th, td = th[keep], td[keep]
    half = np.maximum(tol * np.abs(v), 0.01 * np.median(v))
    warps = {
        "sqrt": np.sqrt(th / (np.pi / 2)),
        "radians": th,
        "roughness a": 2 / np.pi * np.arctan2(np.sin(th), alpha * np.cos(th)),
        "roughness 2a": 2 / np.pi * np.arctan2(np.sin(th), 2 * alpha * np.cos(th)),
    }
    out = {}
    for name, w in warps.items():
        start = time.perf_counter()
        try:
            f = ratfit.fit(np.column_stack([w, td]), v, lo=v - half, hi=v + half, max_coeffs=80, search="staircase")
            out[name] = (f.n_p + f.n_q, time.perf_counter() - start)
        except ratfit.NoFeasibleFit:
            out[name] = (None, time.perf_counter() - start)
    return alpha, out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, default=0.2)
    parser.add_argument("--data", default=os.environ.get("RATFIT_DATA", REPO.parent / "shared" / "data"))
    parser.add_argument("--out", default=REPO / "docs" / "results" / "roughness-warp.md")
    args = parser.parse_args()
    files = sorted((pathlib.Path(args.data) / "rgl").glob("*.bsdf"))
    lines = [
        "# A roughness warp of theta_h, against sqrt and radians",
        "",
        f"Command: `python python/examples/warp_experiment.py --tol {args.tol}` (2 cores). Smallest "
        f"coefficient budget (staircase search, at most 80) of the luminance on the phi_d = pi/2 slice, "
        f"intervals +-{args.tol:.0%} (floor 1% of the median), in each coordinate for theta_h; "
        "'none' = no fit within 80. Fit time in seconds after the count.",
        "",
        "| material | GGX alpha | sqrt | radians | roughness a | roughness 2a |",
        "|---|---|---|---|---|---|",
    ]
    for path in files:
        alpha, out = run(path, args.tol)
        cells = [
            f"{'none' if n is None else n} ({s:.1f} s)" for n, s in out.values()
        ]
        lines.append(f"| {path.stem} | {alpha:.3f} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    pathlib.Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
