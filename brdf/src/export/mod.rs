//! What a fit becomes outside this crate: the f32 form a renderer
//! evaluates (one at a time and batched), its compact binary file, WGSL and
//! GLSL shaders, and ALTA's rational-function files (which this crate also
//! reads back).

pub(crate) mod alta;
pub mod compact;
pub mod compact_batch;
pub mod shader;
