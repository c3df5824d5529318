//! The measured tables ratfit reads by name (`--format merl`, a scene's
//! `format = "rgl"`, Python's `format=`), so every front end accepts the
//! same names, guesses from the same extensions and says the same thing
//! when it cannot.

use crate::{Brdf, BrdfError, MerlBrdf, RglBrdf};
use std::path::Path;
use std::str::FromStr;

/// A tabulated measurement format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum TableFormat {
    /// MERL's binary table (`.binary`, 90 x 90 x 180 cells).
    Merl,
    /// RGL's `.bsdf` tensor file (the isotropic RGB kind).
    Rgl,
}

impl TableFormat {
    /// Every format, in the order the messages list them.
    pub const ALL: [TableFormat; 2] = [TableFormat::Merl, TableFormat::Rgl];

    /// The name used on the command line and in scenes.
    pub fn name(self) -> &'static str {
        match self {
            TableFormat::Merl => "merl",
            TableFormat::Rgl => "rgl",
        }
    }

    /// The format a file's extension names (`.binary`, `.bsdf`), if any.
    pub fn of_path(path: &Path) -> Option<Self> {
        match path.extension()?.to_str()? {
            "binary" => Some(TableFormat::Merl),
            "bsdf" => Some(TableFormat::Rgl),
            _ => None,
        }
    }

    /// Reads the table at `path` in this format, checked.
    ///
    /// # Errors
    /// The reader's: the file cannot be read, or is not of this format.
    pub fn read(self, path: &Path) -> Result<Box<dyn Brdf>, BrdfError> {
        Ok(match self {
            TableFormat::Merl => Box::new(MerlBrdf::read(path)?),
            TableFormat::Rgl => Box::new(RglBrdf::read(path)?),
        })
    }

    /// The bytes the table takes as stored: MERL's fixed size, an RGL
    /// file's length (0 when it cannot be read).
    pub fn stored_bytes(self, path: &Path) -> usize {
        match self {
            TableFormat::Merl => crate::merl::FILE_SIZE,
            TableFormat::Rgl => std::fs::metadata(path).map_or(0, |m| m.len() as usize),
        }
    }
}

impl FromStr for TableFormat {
    type Err = BrdfError;

    fn from_str(s: &str) -> Result<Self, BrdfError> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| BrdfError::Invalid {
                name: "table format",
                reason: format!("unknown format `{s}` (merl, rgl)"),
            })
    }
}

impl std::fmt::Display for TableFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_extensions_round_trip() {
        for f in TableFormat::ALL {
            assert_eq!(f.name().parse::<TableFormat>().unwrap(), f);
        }
        let e = "alta".parse::<TableFormat>().unwrap_err().to_string();
        assert!(e.contains("`alta`") && e.contains("merl, rgl"), "{e}");
        assert_eq!(
            TableFormat::of_path(Path::new("a/gold.binary")),
            Some(TableFormat::Merl)
        );
        assert_eq!(
            TableFormat::of_path(Path::new("felt.bsdf")),
            Some(TableFormat::Rgl)
        );
        assert_eq!(TableFormat::of_path(Path::new("table.txt")), None);
    }

    #[test]
    fn a_file_of_another_format_is_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("ratfit-format-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("short.binary");
        std::fs::write(&path, [0u8; 12]).unwrap();
        for f in TableFormat::ALL {
            let e = f.read(&path).err().expect("refused").to_string();
            assert!(e.contains("short.binary"), "{f}: {e}");
        }
        std::fs::remove_dir_all(dir).ok();
    }
}
