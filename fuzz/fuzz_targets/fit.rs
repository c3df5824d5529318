//! The files ratfit writes for fits and reads back: the fit JSON and the
//! compact binary (the first byte chooses).
#![no_main]
use brdf::{CompactBrdf, FittedBrdf};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    if which % 2 == 0 {
        if let Ok(f) = serde_json::from_slice::<FittedBrdf>(rest) {
            ratfit_fuzz::assert_finite("fit JSON", &f);
        }
    } else if let Ok(c) = CompactBrdf::from_bytes(rest) {
        ratfit_fuzz::assert_finite("compact binary", &c);
    }
});
