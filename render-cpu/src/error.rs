//! Errors of scene loading, preparation, rendering and image input/output.

use thiserror::Error;

/// Everything that can go wrong before or after a render. Rendering itself
/// cannot fail once a scene is prepared.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RenderError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The scene file is not valid TOML or does not describe a scene.
    #[error("scene {path}: {reason}")]
    Scene {
        /// The scene file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A malformed OBJ mesh.
    #[error("{path}:{line}: {reason}")]
    Obj {
        /// The mesh file.
        path: String,
        /// 1-based line number (0 for the whole file).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An image that cannot be read, written or compared.
    #[error("image {path}: {reason}")]
    Image {
        /// The image file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A material that could not be loaded or fitted.
    #[error("material `{name}`: {source}")]
    Material {
        /// The material's name in the scene.
        name: String,
        /// The cause.
        source: brdf::BrdfError,
    },
    /// Inverse CDFs that could not be tabulated or fitted.
    #[error("sampler for material `{name}`: {source}")]
    Sampler {
        /// The material's name in the scene.
        name: String,
        /// The cause.
        source: cdf::CdfError,
    },
    /// An invalid setting.
    #[error("invalid {name}: {reason}")]
    Invalid {
        /// The setting.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

pub(crate) fn invalid(name: &'static str, reason: impl Into<String>) -> RenderError {
    RenderError::Invalid {
        name,
        reason: reason.into(),
    }
}

pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> RenderError {
    RenderError::Io {
        path: path.display().to_string(),
        source,
    }
}
