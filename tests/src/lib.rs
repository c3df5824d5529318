//! The workspace's property and stability suite lives in `tests/`; this
//! library only hosts it. Every test uses the public APIs of the crates.
