//! Headless GPU device: Vulkan (lavapipe on CPU-only machines) first, GL (llvmpipe) as fallback.

use super::RenderError;

/// Which backends to try.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// Vulkan, then GL (or `WGPU_BACKEND` from the environment when set).
    #[default]
    Auto,
    /// Vulkan only.
    Vulkan,
    /// GL only.
    Gl,
}

/// A wgpu device and queue with the adapter they came from.
#[derive(Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter description (name, backend, driver).
    pub adapter_info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// Create a headless device: Vulkan first, GL fallback. Logs the adapter at info level.
    ///
    /// # Errors
    /// [`RenderError::NoAdapter`] when no backend yields an adapter (install
    /// `mesa-vulkan-drivers libvulkan1`), [`RenderError::Device`] when the device cannot be created.
    pub fn new_headless() -> Result<Self, RenderError> {
        Self::with_backend(BackendChoice::Auto)
    }

    /// Create a headless device on a chosen backend.
    ///
    /// # Errors
    /// As [`GpuContext::new_headless`].
    pub fn with_backend(choice: BackendChoice) -> Result<Self, RenderError> {
        let order: Vec<wgpu::Backends> = match choice {
            BackendChoice::Auto => match std::env::var("WGPU_BACKEND") {
                Ok(_) => vec![wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN | wgpu::Backends::GL)],
                Err(_) => vec![wgpu::Backends::VULKAN, wgpu::Backends::GL],
            },
            BackendChoice::Vulkan => vec![wgpu::Backends::VULKAN],
            BackendChoice::Gl => vec![wgpu::Backends::GL],
        };
        let mut reasons = Vec::new();
        for backends in order {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = backends;
            desc.flags = wgpu::InstanceFlags::empty().with_env();
            let instance = wgpu::Instance::new(desc);
            let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                ..Default::default()
            }));
            let adapter = match adapter {
                Ok(a) => a,
                Err(e) => {
                    reasons.push(format!("{backends:?}: {e}"));
                    continue;
                }
            };
            let info = adapter.get_info();
            let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("synthcam"),
                required_features: wgpu::Features::empty(),
                required_limits: adapter.limits(),
                ..Default::default()
            }))
            .map_err(|e| RenderError::Device(e.to_string()))?;
            log::info!("GPU adapter: {} ({:?}, driver {} {})", info.name, info.backend, info.driver, info.driver_info);
            return Ok(Self { device, queue, adapter_info: info });
        }
        Err(RenderError::NoAdapter(reasons.join("; ")))
    }

    /// One line describing the adapter, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) / Vulkan`.
    pub fn describe(&self) -> String {
        format!("{} / {:?}", self.adapter_info.name, self.adapter_info.backend)
    }
}
