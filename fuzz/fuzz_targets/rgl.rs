//! RGL `.bsdf` tensor files.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = brdf::RglBrdf::from_bytes(data, Path::new("fuzz.bsdf"), "fuzz".into()) {
        ratfit_fuzz::assert_finite("RGL file", &m);
    }
});
