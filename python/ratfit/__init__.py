"""Rational functions fitted inside error bounds, and measured BRDFs represented by them.

``ratfit.fit`` finds ``r = p / q`` with ``lo <= r(x) <= hi`` at every sample
(a convex quadratic program per split ``(n_p, n_q)``, the smallest budget
that is feasible): the bound is known before the fit and checked in f64
after it. ``ratfit.fit_brdf`` fits a measured material (MERL or RGL table)
that way and returns a representation that evaluates, exports to shaders and
renders like the table.

    >>> import numpy as np, ratfit
    >>> x = np.linspace(-1, 1, 200)
    >>> f = ratfit.fit(x, 1 / (1 + 25 * x**2), rel_tol=0.01)
    >>> (f.n_p, f.n_q), f.report["verified"]
    ((1, 3), True)

Fits run with the GIL released; Ctrl-C stops one at the next split and
raises ``KeyboardInterrupt``. Bad input raises ``ValueError`` with the
library's message, an unreadable file ``OSError``, and a sweep that finds no
fit :class:`NoFeasibleFit`.
"""

from __future__ import annotations

from typing import Any, Optional, Sequence, Tuple

import numpy as np

from . import _ratfit
from ._ratfit import FittedMaterial, Material, NoFeasibleFit, RationalFit, read_material

__all__ = [
    "fit",
    "fit_brdf",
    "read_material",
    "RationalFit",
    "FittedMaterial",
    "Material",
    "NoFeasibleFit",
    "BRDF_OPTIONS",
]

__version__ = _ratfit.__version__

#: The keyword arguments of :func:`fit_brdf` (the flags of ``ratfit fit``).
BRDF_OPTIONS = (
    "format",
    "dims",
    "spread",
    "coords",
    "rel_tol",
    "noise_floor",
    "max_coeffs",
    "max_theta_d",
    "max_elevation",
    "resolution",
    "backend",
    "poles",
    "search",
    "max_widenings",
    "target_de",
    "time_budget",
    "max_bytes",
    "degree_weights",
    "perceptual",
    "centred",
    "cap_rounds",
    "colour",
    "values",
    "lobe",
    "render_check",
)


def fit(
    x: Any,
    y: Any = None,
    *,
    lo: Any = None,
    hi: Any = None,
    rel_tol: Optional[float] = None,
    abs_tol: Optional[float] = None,
    max_coeffs: int = 40,
    min_coeffs: int = 2,
    basis: str = "chebyshev",
    poles: str = "grid",
    search: str = "exhaustive",
    selection: str = "condition",
    degree_weights: Optional[Sequence[int]] = None,
    domain: Optional[Tuple[Sequence[float], Sequence[float]]] = None,
    max_widenings: int = 0,
    backend: str = "native",
    value_scaling: bool = True,
) -> RationalFit:
    """Fits ``p / q`` inside an interval at every sample.

    Args:
        x: points, shape (s,) for one coordinate or (s, d).
        y: values, shape (s,); required with ``rel_tol`` or ``abs_tol``, and
            kept for the error figures with ``lo``/``hi``.
        lo, hi: the interval of each sample (both, shape (s,)).
        rel_tol: intervals ``y +- rel_tol * |y|``.
        abs_tol: intervals ``y +- abs_tol``.
        max_coeffs, min_coeffs: the budgets ``n_p + n_q`` swept.
        basis: "chebyshev", "legendre" or "monomial".
        poles: "grid" (q checked between samples on a dense grid),
            "bernstein" (certified q > 0 on the box) or "none".
        search: "exhaustive" (every split of every budget) or "staircase"
            (the same smallest budget in far fewer solves).
        selection: "condition" or "depth", among the splits of the budget.
        degree_weights: a unit of degree in coordinate k costs weights[k].
        domain: (lower corner, upper corner) mapped to [-1, 1]^d (default:
            the points' bounding box).
        max_widenings: when no budget fits, double the intervals and sweep
            again, at most this many times (the report says so).
        backend: "native", or a comparison backend compiled in.
        value_scaling: divide the bounds by their largest magnitude before
            solving (default); False is the paper's formulation exactly.

    Returns:
        A :class:`RationalFit`, verified in f64 against every interval.

    Raises:
        ValueError: bad input (NaN, lo > hi, wrong shapes) or settings.
        NoFeasibleFit: no split up to ``max_coeffs`` fits.
    """
    return _ratfit.fit(
        x,
        y,
        lo=lo,
        hi=hi,
        rel_tol=rel_tol,
        abs_tol=abs_tol,
        max_coeffs=max_coeffs,
        min_coeffs=min_coeffs,
        basis=basis,
        poles=poles,
        search=search,
        selection=selection,
        degree_weights=None if degree_weights is None else list(degree_weights),
        domain=None if domain is None else (list(domain[0]), list(domain[1])),
        max_widenings=max_widenings,
        backend=backend,
        value_scaling=value_scaling,
    )


def fit_brdf(path: str, format: Optional[str] = None, **options: Any) -> FittedMaterial:
    """Fits a measured material with three rational functions.

    Args:
        path: a MERL ``.binary`` or RGL ``.bsdf`` file.
        format: "merl" or "rgl" (default: from the extension).
        **options: the flags of ``ratfit fit`` (see :data:`BRDF_OPTIONS`),
            with its defaults: ``dims`` (2 or 3), ``resolution``
            (theta_h, theta_d[, phi_d] bins), ``rel_tol`` (0.05),
            ``perceptual``, ``centred`` (each function the least-squares
            fit within its intervals rather than the point of largest
            margin; always so with ``target_de``), ``max_elevation`` (degrees; default 70 for fits
            at fixed intervals; perceptual and ``target_de`` fits cover the
            whole hemisphere unless it is given, then fit only the cells
            within it and evaluate beyond it at the cut),
            ``cap_rounds`` (refits of the dense check that
            keeps every fit under 1.5x the channel's peak; default 2),
            ``colour`` ("rgb" or "luminance-chroma"; with ``target_de``
            and no ``colour``, luminance-chroma and, when the chroma
            ratios limit the first reduction, RGB there too),
            ``lobe`` (an analytic GGX lobe times the rational functions),
            ``max_coeffs`` (default 60, 120 with ``target_de``, which
            doubles it once for its best search where it rather than
            ``max_bytes`` stopped that search within twice the target, unless
            ``max_coeffs`` is given), ``search`` ("staircase"; "exhaustive" visits every
            split, for the same fits on real materials in several times the
            time), ``target_de`` (the smallest fit whose
            validation renders reach that mean CIEDE2000), ``time_budget``
            (seconds, default 120: past it no fit starts once one within
            the budgets is in hand),
            ``max_bytes`` (with ``target_de``: the most bytes the fit
            returned may have; fits over it are tried, never returned),
            ``render_check`` (default True: render the fit beside the table
            on the two validation scenes and report the CIEDE2000 reached).

    Returns:
        A :class:`FittedMaterial`; its ``report`` says what was reached.

    Raises:
        ValueError: an unknown option or a value out of range, a malformed file.
        OSError: the file cannot be read.
        NoFeasibleFit: a channel has no fit within the budget.
    """
    return _ratfit.fit_brdf(path, dict(options, format=format))
