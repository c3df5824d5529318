//! Paths in scene files and checks of scene values.

use crate::error::{invalid, RenderError};
use crate::math::{dot, Vec3};
use std::path::{Path, PathBuf};

/// Resolves a path in a scene file: relative to the scene's directory, with
/// `$RATFIT_DATA/` the data directory (`RATFIT_DATA`, else a `shared/data`
/// directory above the scene or the working directory).
///
/// # Errors
/// `$RATFIT_DATA/` used but no data directory found.
pub fn resolve_path(base: &Path, p: &str) -> Result<PathBuf, RenderError> {
    if let Some(rest) = p.strip_prefix("$RATFIT_DATA/") {
        return Ok(data_dir(base)?.join(rest));
    }
    let path = Path::new(p);
    Ok(if path.is_absolute() {
        path.to_path_buf()
    } else {
        base.join(path)
    })
}

fn data_dir(base: &Path) -> Result<PathBuf, RenderError> {
    if let Some(d) = std::env::var_os("RATFIT_DATA").filter(|v| !v.is_empty()) {
        return Ok(PathBuf::from(d));
    }
    let cwd = std::env::current_dir().unwrap_or_default();
    let base = if base.is_absolute() {
        base.to_path_buf()
    } else {
        cwd.join(base)
    };
    base.ancestors()
        .chain(cwd.ancestors())
        .map(|a| a.join("shared").join("data"))
        .find(|d| d.is_dir())
        .ok_or_else(|| {
            invalid(
                "data directory",
                format!(
                    "`$RATFIT_DATA/` is used but RATFIT_DATA is not set and no shared/data directory is above {}",
                    base.display()
                ),
            )
        })
}

pub(super) fn scene_error(origin: &str, reason: String) -> RenderError {
    RenderError::Scene {
        path: origin.to_string(),
        reason,
    }
}

pub(super) fn check_vec(
    origin: &str,
    what: &str,
    v: [f64; 3],
    nonzero: bool,
) -> Result<Vec3, RenderError> {
    if v.iter().any(|x| !x.is_finite()) || (nonzero && dot(v, v) <= 0.0) {
        return Err(scene_error(
            origin,
            format!(
                "{what} {v:?} must be finite{}",
                if nonzero { " and non-zero" } else { "" }
            ),
        ));
    }
    Ok(v)
}

/// Largest light colour (radiance, irradiance, intensity) a scene may give:
/// far above any physical scene in any unit, and small enough that sums of
/// thousands of lights stay finite in the f32 image.
pub const MAX_LIGHT_VALUE: f64 = 1e12;

pub(super) fn check_rgb(origin: &str, what: &str, v: [f64; 3]) -> Result<[f64; 3], RenderError> {
    if v.iter()
        .any(|x| !x.is_finite() || *x < 0.0 || *x > MAX_LIGHT_VALUE)
    {
        return Err(scene_error(
            origin,
            format!("{what} {v:?} must be finite, non-negative and at most {MAX_LIGHT_VALUE:e}"),
        ));
    }
    Ok(v)
}

/// A reflectance (albedo, diffuse or specular colour): each component in
/// [0, 1], since above 1 a surface reflects more light than it receives.
pub(super) fn check_reflectance(
    origin: &str,
    what: &str,
    v: [f64; 3],
) -> Result<[f64; 3], RenderError> {
    if v.iter().any(|x| !(0.0..=1.0).contains(x)) {
        return Err(scene_error(
            origin,
            format!(
                "{what} {v:?} must lie in [0, 1] (a reflectance above 1 reflects more light than arrives)"
            ),
        ));
    }
    Ok(v)
}

pub(super) fn check_positive(origin: &str, what: &str, v: f64) -> Result<f64, RenderError> {
    if !(v.is_finite() && v > 0.0) {
        return Err(scene_error(origin, format!("{what} {v} must be positive")));
    }
    Ok(v)
}
