//! The text readers: Cornell spectral samples, ALTA data and ALTA rational
//! functions (the first byte chooses). Accepted data must reduce to samples
//! and channels without panicking. An accepted rational function evaluates
//! without panicking; its values are its own (a file may put a pole
//! anywhere, so inf or NaN there is the function's, not the reader's).
#![no_main]
use brdf::{AltaData, AltaRational, Reduction, ScatteredBrdf};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    match which % 3 {
        0 => {
            if let Ok(s) = ScatteredBrdf::parse_cornell(text, Path::new("fuzz.brdf")) {
                let _ = s.samples(&Reduction::default());
            }
        }
        1 => {
            if let Ok(d) = AltaData::parse(text, Path::new("fuzz.alta")) {
                for k in 0..d.dim_out {
                    let _ = d.channel(k, 0.05);
                }
            }
        }
        _ => {
            if let Ok(f) = AltaRational::parse(text, Path::new("fuzz.brdf")) {
                for c in &f.channels {
                    let mid: Vec<f64> =
                        (0..f.dim_in).map(|k| 0.5 * (c.min[k] + c.max[k])).collect();
                    let _ = c.eval(&mid);
                }
            }
        }
    }
});
