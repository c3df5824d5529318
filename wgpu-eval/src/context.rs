//! The adapter, device and queue, and error capture around GPU work.

use crate::GpuError;
use std::sync::Arc;

/// An open GPU device. Cheap to clone (the handles are shared).
#[derive(Debug, Clone)]
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// Opens the preferred adapter (a discrete GPU when there is one; the
    /// `WGPU_BACKEND` and `WGPU_ADAPTER_NAME` variables are honoured) with
    /// WebGPU's default limits.
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when the machine has no usable adapter,
    /// [`GpuError::Device`] when the adapter refuses the device.
    pub fn new() -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(
            &instance, None,
        ))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("ratfit"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::default(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        // Every operation runs inside error scopes; anything that escapes
        // them is reported rather than aborting the process.
        device.on_uncaptured_error(Arc::new(|e| eprintln!("wgpu: uncaptured error: {e}")));
        Ok(Self {
            device,
            queue,
            info,
        })
    }

    /// The adapter as users know it: name, device type, backend and driver.
    pub fn adapter_name(&self) -> String {
        let i = &self.info;
        let driver = if i.driver_info.is_empty() {
            i.driver.clone()
        } else {
            format!("{} {}", i.driver, i.driver_info)
        };
        format!(
            "{} ({:?}, {:?}, {})",
            i.name,
            i.device_type,
            i.backend,
            driver.trim()
        )
    }

    /// Whether the adapter is a CPU implementation (lavapipe, WARP, ...).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Runs `f`, turning validation and out-of-memory errors it causes into
    /// [`GpuError::Gpu`].
    pub(crate) fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let out = f();
        let oom = pollster::block_on(memory.pop());
        let invalid = pollster::block_on(validation.pop());
        match oom.or(invalid) {
            Some(e) => Err(GpuError::Gpu {
                what: what.to_string(),
                reason: e.to_string(),
            }),
            None => Ok(out),
        }
    }

    /// Waits until the queue is idle.
    pub(crate) fn wait(&self, what: &str) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Gpu {
                what: what.to_string(),
                reason: e.to_string(),
            })
    }

    /// Copies the first `size` bytes of a `MAP_READ` buffer back as f32
    /// values (decoded from bytes: a byte vector need not be 4-aligned).
    pub(crate) fn read_back(
        &self,
        buffer: &wgpu::Buffer,
        size: u64,
        what: &str,
    ) -> Result<Vec<f32>, GpuError> {
        let slice = buffer.slice(..size);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait(what)?;
        let gpu = |reason: String| GpuError::Gpu {
            what: what.to_string(),
            reason,
        };
        rx.recv()
            .map_err(|e| gpu(e.to_string()))?
            .map_err(|e| gpu(e.to_string()))?;
        let values = {
            let view = slice.get_mapped_range().map_err(|e| gpu(e.to_string()))?;
            view.chunks_exact(4)
                .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        };
        buffer.unmap();
        Ok(values)
    }
}
