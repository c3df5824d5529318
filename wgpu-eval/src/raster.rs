//! The directional-light renderer: rasterises the scene's triangles and
//! shades every pixel centre with all lights in one fragment shader.

use crate::scene::{GpuLight, GpuScene, Vertex};
use crate::wgsl::render_shader;
use crate::{GpuContext, GpuError};
use render_cpu::Image;
use std::time::Instant;

const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A scene compiled for the GPU: pipeline, buffers and render targets.
#[derive(Debug)]
pub struct GpuRenderer {
    ctx: GpuContext,
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    width: u32,
    height: u32,
}

/// How long frames took.
#[derive(Debug, Clone, Copy)]
pub struct FrameTiming {
    /// Frames timed (after one warm-up frame).
    pub frames: usize,
    /// Median seconds per frame over the timed batches.
    pub seconds_per_frame: f64,
    /// Seconds for the shader compilation and the first frame.
    pub first_frame_seconds: f64,
}

impl GpuRenderer {
    /// Compiles `scene`'s shader (materials as generated WGSL, lights in a
    /// uniform buffer) and allocates its buffers.
    ///
    /// # Errors
    /// [`GpuError::Invalid`] for an empty image or a scene without
    /// triangles, [`GpuError::Gpu`] when the device rejects something.
    pub fn new(ctx: &GpuContext, scene: &GpuScene) -> Result<Self, GpuError> {
        let max = ctx.device.limits().max_texture_dimension_2d;
        let side = |v: usize| u32::try_from(v).ok().filter(|&v| v > 0 && v <= max);
        let (Some(width), Some(height)) = (side(scene.width), side(scene.height)) else {
            return Err(GpuError::Invalid(format!(
                "image size {}x{} (1 to {max} pixels a side)",
                scene.width, scene.height
            )));
        };
        if scene.vertices.is_empty() {
            return Err(GpuError::Invalid("the scene has no triangles".into()));
        }
        let source = render_shader(&scene.materials, scene.lights.len())?;
        let globals = globals_words(scene);
        let mut lights = scene.lights.clone();
        if lights.is_empty() {
            lights.push(GpuLight {
                where_: [0.0; 4],
                power: [0.0; 4],
            });
        }
        let padded_row = (width * 16).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let d = &ctx.device;
        let built = ctx.scoped("building the renderer", || {
            let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("ratfit render"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            let uniform = |label: &str, bytes: &[u8]| {
                let b = d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.len() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                ctx.queue.write_buffer(&b, 0, bytes);
                b
            };
            let globals = uniform("globals", bytemuck::cast_slice(&globals));
            let lights = uniform("lights", bytemuck::cast_slice(&lights));
            let vertices = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vertices"),
                size: std::mem::size_of_val(scene.vertices.as_slice()) as u64,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.queue
                .write_buffer(&vertices, 0, bytemuck::cast_slice(&scene.vertices));
            let pipeline = render_pipeline(d, &module);
            let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("ratfit render"),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: globals.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: lights.as_entire_binding(),
                    },
                ],
            });
            let (color, depth, readback) = frame_targets(d, width, height, padded_row);
            (pipeline, bind_group, vertices, color, depth, readback)
        })?;
        let (pipeline, bind_group, vertices, color, depth, readback) = built;
        let color_view = color.create_view(&Default::default());
        let depth_view = depth.create_view(&Default::default());
        Ok(Self {
            ctx: ctx.clone(),
            pipeline,
            bind_group,
            vertices,
            vertex_count: scene.vertices.len() as u32,
            color,
            color_view,
            depth_view,
            readback,
            padded_row,
            width,
            height,
        })
    }

    fn frame(&self, copy: bool) -> wgpu::CommandBuffer {
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.color_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.draw(0..self.vertex_count, 0..1);
        }
        if copy {
            encoder.copy_texture_to_buffer(
                self.color.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &self.readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(self.padded_row),
                        rows_per_image: Some(self.height),
                    },
                },
                wgpu::Extent3d {
                    width: self.width,
                    height: self.height,
                    depth_or_array_layers: 1,
                },
            );
        }
        encoder.finish()
    }

    /// Renders one frame and reads it back (linear radiance).
    ///
    /// # Errors
    /// [`GpuError::Gpu`] for a device error.
    pub fn render(&self) -> Result<Image, GpuError> {
        let commands = self.frame(true);
        self.ctx
            .scoped("rendering", || self.ctx.queue.submit([commands]))?;
        let values = self.ctx.read_back(
            &self.readback,
            self.padded_row as u64 * self.height as u64,
            "reading the image",
        )?;
        let (w, h) = (self.width as usize, self.height as usize);
        let row_floats = self.padded_row as usize / 4;
        let mut pixels = Vec::with_capacity(w * h);
        for y in 0..h {
            let row = &values[y * row_floats..][..w * 4];
            pixels.extend(row.chunks_exact(4).map(|p| [p[0], p[1], p[2]]));
        }
        Ok(Image::new(w, h, pixels))
    }

    /// Frame time: one warm-up frame (which includes the driver's shader
    /// compilation), then `frames` frames in batches of at most 8 submitted
    /// together, each batch timed until the queue is idle; the median batch
    /// gives seconds per frame.
    ///
    /// # Errors
    /// [`GpuError::Gpu`] for a device error; [`GpuError::Invalid`] for zero frames.
    pub fn time_frames(&self, frames: usize) -> Result<FrameTiming, GpuError> {
        if frames == 0 {
            return Err(GpuError::Invalid("timing needs at least one frame".into()));
        }
        let start = Instant::now();
        let warm = self.frame(false);
        self.ctx
            .scoped("rendering", || self.ctx.queue.submit([warm]))?;
        self.ctx.wait("rendering")?;
        let first_frame_seconds = start.elapsed().as_secs_f64();
        let mut per_frame = Vec::new();
        let mut left = frames;
        while left > 0 {
            let n = left.min(8);
            let start = Instant::now();
            for _ in 0..n {
                let c = self.frame(false);
                self.ctx
                    .scoped("rendering", || self.ctx.queue.submit([c]))?;
            }
            self.ctx.wait("rendering")?;
            per_frame.push(start.elapsed().as_secs_f64() / n as f64);
            left -= n;
        }
        per_frame.sort_by(f64::total_cmp);
        Ok(FrameTiming {
            frames,
            seconds_per_frame: per_frame[per_frame.len() / 2],
            first_frame_seconds,
        })
    }
}

/// The globals uniform: eye, forward, right and up (vec4 each), the
/// projection scales and depth range, then the light count.
fn globals_words(scene: &GpuScene) -> Vec<u32> {
    let (eye, forward, right, up, tan_half) = scene.camera;
    let aspect = scene.width as f64 / scene.height as f64;
    let (near, far) = scene.depth_range();
    let v4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
    let mut globals: Vec<f32> = Vec::with_capacity(24);
    for v in [eye, forward, right, up] {
        globals.extend_from_slice(&v4(v));
    }
    globals.extend_from_slice(&[
        (1.0 / (tan_half * aspect)) as f32,
        (1.0 / tan_half) as f32,
        near,
        far,
    ]);
    let mut globals: Vec<u32> = globals.iter().map(|v| v.to_bits()).collect();
    globals.extend_from_slice(&[scene.lights.len() as u32, 0, 0, 0]);
    globals
}

/// The colour and depth targets of a `width` x `height` frame, and the
/// buffer the colour image is copied to (rows padded to `padded_row` bytes).
fn frame_targets(
    d: &wgpu::Device,
    width: u32,
    height: u32,
    padded_row: u32,
) -> (wgpu::Texture, wgpu::Texture, wgpu::Buffer) {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    let target = |label: &str, format, usage| {
        d.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let color = target(
        "colour",
        COLOR,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let depth = target("depth", DEPTH, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let readback = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("image readback"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    (color, depth, readback)
}

/// The pipeline: one vertex buffer of [`Vertex`], depth test, no culling,
/// the colour target unblended.
fn render_pipeline(d: &wgpu::Device, module: &wgpu::ShaderModule) -> wgpu::RenderPipeline {
    d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("ratfit render"),
        layout: None,
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![
                    0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Uint32
                ],
            })],
        },
        primitive: wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: COLOR,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
