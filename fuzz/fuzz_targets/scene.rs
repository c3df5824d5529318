//! Scene descriptions (TOML): parsing and the checks made before anything
//! is loaded or allocated.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = render_cpu::SceneDescription::parse(text, "fuzz scene");
    }
});
