//! Batch evaluation of a fitted BRDF at many direction pairs (compute).

use crate::wgsl::{batch_shader, WORKGROUP};
use crate::{GpuContext, GpuError};
use brdf::CompactBrdf;
use std::time::Instant;

/// Pairs per dispatch: 32 MiB of directions in, 16 MiB of values out,
/// within WebGPU's default buffer limits and its 65,535 work groups.
const CHUNK: usize = 1 << 20;

/// A fitted BRDF compiled into a compute kernel.
#[derive(Debug)]
pub struct BatchEvaluator {
    ctx: GpuContext,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    coefficients: usize,
}

/// A direction pair `(wi, wo)`, unit vectors in the local frame (z the normal).
pub type DirectionPair = ([f32; 3], [f32; 3]);

struct Buffers {
    params: wgpu::Buffer,
    pairs: wgpu::Buffer,
    values: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

impl BatchEvaluator {
    /// Compiles `fit`'s exported WGSL (`brdf::shader`) into a kernel.
    ///
    /// # Errors
    /// [`GpuError::Invalid`] for a fit without channels, [`GpuError::Gpu`]
    /// when the driver rejects the shader.
    pub fn new(ctx: &GpuContext, fit: &CompactBrdf) -> Result<Self, GpuError> {
        if fit.channels.len() != 3 {
            return Err(GpuError::Invalid(format!(
                "the fit has {} channels; the kernel evaluates RGB fits",
                fit.channels.len()
            )));
        }
        let source = batch_shader(fit);
        let (pipeline, layout) = ctx.scoped("compiling the evaluation kernel", || {
            let module = ctx
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("ratfit batch evaluation"),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
            let pipeline = ctx
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("ratfit batch evaluation"),
                    layout: None,
                    module: &module,
                    entry_point: Some("eval_main"),
                    compilation_options: Default::default(),
                    cache: None,
                });
            let layout = pipeline.get_bind_group_layout(0);
            (pipeline, layout)
        })?;
        let coefficients = fit.channels.iter().map(|c| c.num.len() + c.den.len()).sum();
        Ok(Self {
            ctx: ctx.clone(),
            pipeline,
            layout,
            coefficients,
        })
    }

    /// Coefficients of the fit (all channels).
    pub fn coefficients(&self) -> usize {
        self.coefficients
    }

    fn buffers(&self, capacity: usize) -> Result<Buffers, GpuError> {
        let d = &self.ctx.device;
        self.ctx.scoped("allocating evaluation buffers", || {
            let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
            let params = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let pairs = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pairs"),
                size: (capacity * 32) as u64,
                usage,
                mapped_at_creation: false,
            });
            let values = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("values"),
                size: (capacity * 16) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("values readback"),
                size: (capacity * 16) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("evaluation"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: pairs.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: values.as_entire_binding(),
                    },
                ],
            });
            Buffers {
                params,
                pairs,
                values,
                readback,
                bind_group,
            }
        })
    }

    fn upload(&self, b: &Buffers, pairs: &[DirectionPair]) -> Result<(), GpuError> {
        let mut data = Vec::with_capacity(pairs.len() * 8);
        for (k, (wi, wo)) in pairs.iter().enumerate() {
            if !wi.iter().chain(wo.iter()).all(|v| v.is_finite()) {
                return Err(GpuError::Invalid(format!(
                    "direction pair {k} is not finite: {wi:?}, {wo:?}"
                )));
            }
            data.extend_from_slice(&[wi[0], wi[1], wi[2], 0.0, wo[0], wo[1], wo[2], 0.0]);
        }
        let count = [pairs.len() as u32, 0, 0, 0];
        self.ctx.scoped("uploading directions", || {
            self.ctx
                .queue
                .write_buffer(&b.params, 0, bytemuck::cast_slice(&count));
            self.ctx
                .queue
                .write_buffer(&b.pairs, 0, bytemuck::cast_slice(&data));
        })
    }

    fn dispatch(&self, b: &Buffers, count: usize, copy: bool) -> wgpu::CommandBuffer {
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("evaluation"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("evaluation"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &b.bind_group, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(WORKGROUP), 1, 1);
        }
        if copy {
            encoder.copy_buffer_to_buffer(&b.values, 0, &b.readback, 0, (count * 16) as u64);
        }
        encoder.finish()
    }

    /// RGB values at every pair, in order (zero below the horizon, as the
    /// exported shader defines).
    ///
    /// # Errors
    /// [`GpuError::Invalid`] for a non-finite direction, [`GpuError::Gpu`]
    /// for a device error.
    pub fn eval(&self, pairs: &[DirectionPair]) -> Result<Vec<[f32; 3]>, GpuError> {
        let mut out = Vec::with_capacity(pairs.len());
        if pairs.is_empty() {
            return Ok(out);
        }
        let b = self.buffers(pairs.len().min(CHUNK))?;
        for chunk in pairs.chunks(CHUNK) {
            self.upload(&b, chunk)?;
            let commands = self.dispatch(&b, chunk.len(), true);
            self.ctx
                .scoped("evaluating", || self.ctx.queue.submit([commands]))?;
            let values =
                self.ctx
                    .read_back(&b.readback, (chunk.len() * 16) as u64, "reading values")?;
            out.extend(values.chunks_exact(4).map(|v| [v[0], v[1], v[2]]));
        }
        Ok(out)
    }

    /// Seconds per evaluation of `pairs` (at most 2^20) with the data
    /// already on the device: `repeats` dispatches after one warm-up,
    /// timed from the first submission until the queue is idle.
    ///
    /// # Errors
    /// As [`BatchEvaluator::eval`]; [`GpuError::Invalid`] for an empty or
    /// oversized batch.
    pub fn time_resident(&self, pairs: &[DirectionPair], repeats: usize) -> Result<f64, GpuError> {
        if pairs.is_empty() || pairs.len() > CHUNK || repeats == 0 {
            return Err(GpuError::Invalid(format!(
                "timing needs 1 to {CHUNK} pairs and at least one repeat (got {} pairs, {repeats} repeats)",
                pairs.len()
            )));
        }
        let b = self.buffers(pairs.len())?;
        self.upload(&b, pairs)?;
        let warm = self.dispatch(&b, pairs.len(), false);
        self.ctx
            .scoped("evaluating", || self.ctx.queue.submit([warm]))?;
        self.ctx.wait("evaluating")?;
        let start = Instant::now();
        for _ in 0..repeats {
            let c = self.dispatch(&b, pairs.len(), false);
            self.ctx
                .scoped("evaluating", || self.ctx.queue.submit([c]))?;
        }
        self.ctx.wait("evaluating")?;
        Ok(start.elapsed().as_secs_f64() / repeats as f64)
    }
}
