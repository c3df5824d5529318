//! Value parsers of numeric flags: every range is checked where the flag is
//! read, and the error names the flag's rule and the value given (clap adds
//! the flag's name).

/// A finite number, for the parsers below.
fn finite(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{v} is not finite"))
    }
}

/// An angle in degrees in `(0, 90]`.
pub fn angle_deg(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v > 0.0 && v <= 90.0 {
        Ok(v)
    } else {
        Err(format!("{v} degrees is outside (0, 90]"))
    }
}

/// A relative half-width in `(0, 1)`: at 1 or more the interval reaches zero.
pub fn relative_tolerance(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v} is outside (0, 1) (a relative half-width of 1 or more lets the fit reach zero)"
        ))
    }
}

/// A fraction in `[0, 1)`.
pub fn fraction(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside [0, 1)"))
    }
}

/// A ratio of variances to stay within: finite and at least 1.
pub fn ratio(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v >= 1.0 {
        Ok(v)
    } else {
        Err(format!("{v} must be at least 1"))
    }
}

/// A positive finite number.
pub fn positive(s: &str) -> Result<f64, String> {
    let v = finite(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} must be positive"))
    }
}

/// A count in `1..=max`.
fn count(s: &str, max: usize) -> Result<usize, String> {
    let v: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (1..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside 1..={max}"))
    }
}

/// Samples of an estimate: `1..=10^10`.
pub fn samples(s: &str) -> Result<usize, String> {
    count(s, 10_000_000_000)
}

/// Samples per pixel: `1..=2^20`.
pub fn spp(s: &str) -> Result<usize, String> {
    count(s, 1 << 20)
}

/// Refits of the dense cap check: `0..=`[`brdf::MAX_CAP_ROUNDS`].
pub fn cap_rounds(s: &str) -> Result<usize, String> {
    let v: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if v <= brdf::MAX_CAP_ROUNDS {
        Ok(v)
    } else {
        Err(format!("{v} is outside 0..={}", brdf::MAX_CAP_ROUNDS))
    }
}

/// A coefficient budget: `2..=`[`rational_core::MAX_BASIS_LEN`].
pub fn coefficients(s: &str) -> Result<usize, String> {
    let v = count(s, rational_core::MAX_BASIS_LEN)?;
    if v >= 2 {
        Ok(v)
    } else {
        Err("a budget needs at least 2 coefficients (one each for p and q)".into())
    }
}

/// A byte budget of a fit: `8..=2^30` (two f32 coefficients at least).
pub fn max_bytes(s: &str) -> Result<usize, String> {
    let v = count(s, 1 << 30)?;
    if v >= 8 {
        Ok(v)
    } else {
        Err(format!(
            "{v} bytes cannot hold a rational function (at least 2 coefficients of 4 bytes)"
        ))
    }
}

/// Bin counts of a BRDF grid (a type of its own: clap reads a `Vec` field
/// as a repeated flag).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bins(pub Vec<usize>);

/// `NH,ND[,NP]` bin counts of a BRDF grid, each in `2..=`[`brdf::MAX_BINS`].
pub fn bins(s: &str) -> Result<Bins, String> {
    let v: Vec<usize> = s
        .split(',')
        .map(|p| count(p, brdf::MAX_BINS))
        .collect::<Result<_, _>>()?;
    if !(2..=3).contains(&v.len()) {
        return Err(format!("`{s}`: give two or three bin counts, NH,ND[,NP]"));
    }
    if v.iter().any(|&n| n < 2) {
        return Err(format!("`{s}`: every bin count must be at least 2"));
    }
    Ok(Bins(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parsers_refuse_what_they_must() {
        for bad in ["nan", "inf", "-5", "0", "91", "x"] {
            assert!(angle_deg(bad).is_err(), "{bad}");
        }
        assert_eq!(angle_deg("78"), Ok(78.0));
        for bad in ["5", "1", "0", "-0.1", "NaN"] {
            assert!(relative_tolerance(bad).is_err(), "{bad}");
        }
        assert_eq!(relative_tolerance("0.05"), Ok(0.05));
        assert!(fraction("1").is_err() && fraction("0").is_ok());
        assert!(positive("0").is_err() && positive("inf").is_err() && positive("2").is_ok());
        assert!(samples("0").is_err() && samples("18446744073709551615").is_err());
        assert!(spp("1000000000000").is_err() && spp("16").is_ok());
        assert!(coefficients("1").is_err() && coefficients("60").is_ok());
        assert!(max_bytes("4").is_err() && max_bytes("2000000000").is_err());
        assert_eq!(max_bytes("1024"), Ok(1024));
        assert!(bins("100000,100000").is_err());
        assert!(bins("24,24,24,24").is_err());
        assert!(bins("24").is_err());
        assert!(bins("1,24").is_err());
        assert_eq!(bins("24,24,12"), Ok(Bins(vec![24, 24, 12])));
    }
}
