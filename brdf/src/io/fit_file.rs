//! The fit file `ratfit fit` writes: a JSON object whose `brdf` entry is a
//! [`FittedBrdf`], beside reports (`report`, `render`, `target`, `peak`...)
//! that readers keep but do not need. Every reader of fits (the CLI, the
//! scenes, the Python package) goes through [`FitFile`], so they accept and
//! refuse the same files with the same messages.

use crate::{BrdfError, FittedBrdf};
use serde_json::{Map, Value};
use std::path::Path;

const FORMAT: &str = "fit";

/// A fit file: the fitted BRDF, checked on load, and the other entries.
#[derive(Debug, Clone, PartialEq)]
pub struct FitFile {
    /// The fitted BRDF (validated: [`FittedBrdf::validate`]).
    pub brdf: FittedBrdf,
    /// Every other top-level entry, as written.
    pub extra: Map<String, Value>,
}

impl FitFile {
    /// A file holding `brdf` and no reports.
    pub fn new(brdf: FittedBrdf) -> Self {
        Self {
            brdf,
            extra: Map::new(),
        }
    }

    /// Reads and checks the fit file at `path`.
    ///
    /// # Errors
    /// [`BrdfError::Io`] when the file cannot be read;
    /// [`BrdfError::Malformed`] when it is not JSON, has no `brdf` entry or
    /// that entry is not a valid fitted BRDF (naming the file and why).
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// As [`FitFile::read`] on text already read; `path` names it in errors.
    ///
    /// # Errors
    /// As [`FitFile::read`], but for reading.
    pub fn parse(text: &str, path: &Path) -> Result<Self, BrdfError> {
        let value: Value = serde_json::from_str(text)
            .map_err(|e| BrdfError::malformed(path, FORMAT, format!("not JSON: {e}")))?;
        Self::from_value(value, path)
    }

    /// The fit file held by a JSON value; `path` names it in errors.
    ///
    /// # Errors
    /// [`BrdfError::Malformed`] when the value is not an object with a
    /// valid `brdf` entry.
    pub fn from_value(value: Value, path: &Path) -> Result<Self, BrdfError> {
        let Value::Object(mut extra) = value else {
            return Err(BrdfError::malformed(
                path,
                FORMAT,
                "not an object with a `brdf` entry (write one with `ratfit fit`)",
            ));
        };
        let brdf = extra.remove("brdf").ok_or_else(|| {
            BrdfError::malformed(
                path,
                FORMAT,
                "no `brdf` entry (write one with `ratfit fit`)",
            )
        })?;
        let brdf = serde_json::from_value(brdf).map_err(|e| {
            BrdfError::malformed(path, FORMAT, format!("malformed fitted BRDF: {e}"))
        })?;
        Ok(Self { brdf, extra })
    }

    /// Whether a JSON value is meant as a fit file (an object with a `brdf`
    /// entry), valid or not: how commands that also take other JSON tell
    /// them apart.
    pub fn is_fit_file(value: &Value) -> bool {
        value.get("brdf").is_some()
    }

    /// The file's JSON: `brdf` first, then the other entries.
    pub fn to_value(&self) -> Value {
        let mut map = Map::new();
        map.insert(
            "brdf".into(),
            serde_json::to_value(&self.brdf).expect("a fitted BRDF serialises"),
        );
        map.extend(self.extra.clone());
        Value::Object(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{fit_brdf, BrdfFitSettings, Lambert, MerlBrdf, TabulateOptions};

    fn small_fit() -> FittedBrdf {
        let table = MerlBrdf::tabulate(
            &Lambert {
                albedo: [0.2, 0.4, 0.6],
            },
            TabulateOptions::default(),
        );
        fit_brdf(&table, &BrdfFitSettings::default()).unwrap().0
    }

    #[test]
    fn a_written_file_reads_back_with_its_reports() {
        let mut file = FitFile::new(small_fit());
        file.extra.insert("report".into(), Value::from("kept"));
        let text = serde_json::to_string(&file.to_value()).unwrap();
        let back = FitFile::parse(&text, Path::new("x.json")).unwrap();
        assert_eq!(back, file);
    }

    #[test]
    fn files_that_are_not_fits_are_refused_by_name() {
        let path = Path::new("bad.json");
        for (text, says) in [
            ("{", "not JSON"),
            ("[1, 2]", "not an object"),
            ("{\"report\": 1}", "no `brdf` entry"),
            ("{\"brdf\": {\"name\": \"x\"}}", "malformed fitted BRDF"),
        ] {
            let e = FitFile::parse(text, path).unwrap_err().to_string();
            assert!(e.contains("bad.json") && e.contains(says), "{text}: {e}");
        }
        // A valid fit edited to two channels fails its check on load.
        let mut value = FitFile::new(small_fit()).to_value();
        value["brdf"]["channels"].as_array_mut().unwrap().pop();
        let e = FitFile::from_value(value, path).unwrap_err().to_string();
        assert!(e.contains("channels"), "{e}");
        assert!(!FitFile::is_fit_file(&serde_json::json!({"functions": []})));
    }
}
