//! Fitted inverse CDF files: an accepted one samples and weighs directions
//! without panicking, and every weight it returns is finite and positive.
#![no_main]
use brdf::from_spherical;
use cdf::{RationalCdf, RationalSampler, Sampler};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(cdf) = RationalCdf::from_json(text) else {
        return;
    };
    let sampler = RationalSampler::new(cdf);
    for (view, u) in [(0.0, [0.3, 0.6]), (0.7, [0.01, 0.99]), (1.4, [0.5, 0.25])] {
        let wo = from_spherical(view, 0.2);
        if let Some(s) = sampler.sample(wo, u) {
            assert!(
                s.inv_pdf.is_finite() && s.inv_pdf > 0.0,
                "inverse CDF accepted, then sampled with weight {}",
                s.inv_pdf
            );
            let _ = sampler.pdf(wo, s.wi);
        }
    }
});
