//! The crate's error type.

/// What can go wrong on the GPU side.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter could be opened (no GPU and no software Vulkan driver).
    #[error("no GPU adapter: {0} (a GPU driver or Mesa's software Vulkan, Debian package `mesa-vulkan-drivers`, is needed)")]
    NoAdapter(String),
    /// The adapter refused the device.
    #[error("could not open a device on {adapter}: {reason}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// What the driver said.
        reason: String,
    },
    /// The GPU reported an error (shader compilation, validation, memory).
    #[error("GPU error in {what}: {reason}")]
    Gpu {
        /// The operation.
        what: String,
        /// What wgpu said.
        reason: String,
    },
    /// The scene uses something the GPU renderer does not draw.
    #[error("the GPU renderer cannot draw this scene: {0}")]
    Unsupported(String),
    /// Bad input (non-finite directions, an empty fit).
    #[error("invalid input: {0}")]
    Invalid(String),
    /// A BRDF export failed.
    #[error(transparent)]
    Brdf(#[from] brdf::BrdfError),
}
