//! What every fuzz target asserts of an input its reader accepted: the
//! material evaluates to finite values on direction pairs that cover the
//! hemisphere's corners (normal, grazing, opposite azimuths). A reader may
//! refuse any input; it may not panic, hang, abort on an allocation, or
//! accept one that evaluates to inf or NaN.

use brdf::{from_spherical, Brdf};

/// `(theta_i, phi_i), (theta_o, phi_o)` pairs, radians.
const PAIRS: [((f64, f64), (f64, f64)); 5] = [
    ((0.3, 0.1), (0.5, 2.0)),
    ((1.2, 0.0), (1.3, 3.0)),
    ((0.0, 0.0), (0.0, 0.0)),
    ((1.55, 1.0), (0.2, -2.0)),
    ((0.7, -3.1), (1.57, 3.1)),
];

/// Panics (a finding) when `material` evaluates to a non-finite value.
pub fn assert_finite(what: &str, material: &dyn Brdf) {
    for ((ti, pi), (to, po)) in PAIRS {
        let v = material.eval(from_spherical(ti, pi), from_spherical(to, po));
        assert!(
            v.iter().all(|x| x.is_finite()),
            "{what} accepted, then evaluated to {v:?} at ({ti}, {pi}), ({to}, {po})"
        );
    }
}
