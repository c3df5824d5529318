//! The cache of fits and inverse CDFs, keyed by content hashes.

use std::path::{Path, PathBuf};

use super::RenderOptions;

/// Version of cached files; bump when fits change (3: fits carry a ceiling
/// on their values; 4: azimuth maps fitted to reciprocal intervals).
pub(super) const CACHE_VERSION: &str = "ratfit-render-cache-4";
/// FNV-1a, 64 bits: a content key for cache files (the cached file also
/// stores the full settings, checked on load).
pub fn content_hash(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for &b in *p {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        // Separate parts so that ("ab", "c") and ("a", "bc") differ.
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

pub(super) struct Cache {
    dir: Option<PathBuf>,
}

impl Cache {
    pub(super) fn new(options: &RenderOptions) -> Self {
        if options.no_cache {
            return Self { dir: None };
        }
        let env = |k: &str| {
            std::env::var_os(k)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        let dir = options
            .cache_dir
            .clone()
            .or_else(|| env("RATFIT_CACHE"))
            .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("ratfit")))
            .or_else(|| env("HOME").map(|d| d.join(".cache").join("ratfit")));
        Self { dir }
    }

    fn path(&self, kind: &str, key: u64) -> Option<PathBuf> {
        self.dir
            .as_ref()
            .map(|d| d.join(format!("{kind}-{key:016x}.json")))
    }

    /// The cached payload for `settings`, if present and made with them.
    pub(super) fn get(&self, kind: &str, key: u64, settings: &str) -> Option<serde_json::Value> {
        let text = std::fs::read_to_string(self.path(kind, key)?).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        (v.get("settings")?.as_str()? == settings).then(|| v.get("payload").cloned())?
    }

    /// Stores a payload; a cache that cannot be written is not an error
    /// (the log says so).
    pub(super) fn put(
        &self,
        kind: &str,
        key: u64,
        settings: &str,
        payload: serde_json::Value,
    ) -> String {
        let Some(path) = self.path(kind, key) else {
            return "not cached (no cache directory)".into();
        };
        let doc = serde_json::json!({ "settings": settings, "payload": payload });
        let write = || -> std::io::Result<()> {
            std::fs::create_dir_all(path.parent().unwrap_or(Path::new(".")))?;
            brdf::write_atomic(&path, |tmp| std::fs::write(tmp, doc.to_string()))
        };
        match write() {
            Ok(()) => format!("cached as {}", path.display()),
            Err(e) => format!("not cached ({}: {e})", path.display()),
        }
    }
}
