//! The files ratfit writes for fits and reads back: the fit JSON (the bare
//! fitted BRDF, and the fit file around it) and the compact binary (the
//! first byte chooses).
#![no_main]
use brdf::{CompactBrdf, FitFile, FittedBrdf};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    if which % 2 == 0 {
        if let Ok(f) = serde_json::from_slice::<FittedBrdf>(rest) {
            ratfit_fuzz::assert_finite("fit JSON", &f);
        }
        let file = std::str::from_utf8(rest)
            .ok()
            .and_then(|text| FitFile::parse(text, std::path::Path::new("fuzz.json")).ok());
        if let Some(file) = file {
            ratfit_fuzz::assert_finite("fit file", &file.brdf);
        }
    } else if let Ok(c) = CompactBrdf::from_bytes(rest) {
        ratfit_fuzz::assert_finite("compact binary", &c);
    }
});
