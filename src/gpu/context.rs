//! Adapter selection and device creation. Prefers a real GPU; falls back to a software adapter
//! (Mesa lavapipe on Vulkan, or llvmpipe on GL) and says so. Requests the adapter's own limits
//! (wgpu's defaults allow only 256 MiB buffers).

use std::fmt;

use thiserror::Error;

/// Why GPU work could not be set up or did not complete.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No adapter of the wanted kind was found.
    #[error(
        "no {wanted} adapter found (adapters seen: {seen}). On Debian/Ubuntu install the software \
         Vulkan driver with `bash scripts/install-vulkan.sh` (or `apt-get install libvulkan1 \
         mesa-vulkan-drivers`); with a GPU, install its vendor's Vulkan driver. `--adapter auto` \
         takes whatever is there; `--set solver.backend=native` (or `auto`) runs the CPU backend, \
         which needs no adapter."
    )]
    NoAdapter {
        /// The kind asked for.
        wanted: AdapterChoice,
        /// The adapters present, described (`none` if there are none).
        seen: String,
    },
    /// The adapter refused to create a device.
    #[error("the adapter {adapter} refused to create a device: {message}")]
    Device {
        /// The adapter, described.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A wait or a buffer mapping failed; wgpu's message.
    #[error("GPU operation failed: {0}")]
    Operation(String),
    /// A kernel needs more of a device limit than the adapter allows.
    #[error(
        "kernel `{kernel}` needs {limit} >= {need}, but the adapter {adapter} allows {have}: \
         choose another adapter (`--adapter`; `fluxswarm-gpu info` lists them), e.g. Mesa's \
         lavapipe (`bash scripts/install-vulkan.sh`)"
    )]
    Limit {
        /// The kernel's entry point.
        kernel: &'static str,
        /// Name of the `wgpu::Limits` field.
        limit: &'static str,
        /// What the kernel needs.
        need: u32,
        /// What the adapter allows.
        have: u32,
        /// The adapter, described.
        adapter: String,
    },
    /// wgpu rejected a command (a validation error); its results are void.
    #[error(
        "the GPU rejected a command ({0}); its results are void. This is a bug in fluxswarm-gpu: please report it with the command line and `fluxswarm-gpu info`"
    )]
    Rejected(String),
}

/// Which kind of adapter to run on (`--adapter`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum AdapterChoice {
    /// A real GPU when present, otherwise the software adapter.
    #[default]
    Auto,
    /// A real GPU only.
    Gpu,
    /// The software adapter only (lavapipe / llvmpipe).
    Cpu,
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AdapterChoice::Auto => "usable",
            AdapterChoice::Gpu => "GPU",
            AdapterChoice::Cpu => "software (CPU)",
        })
    }
}

/// A device and queue with what we know about the adapter behind them (cheap to clone: the
/// handles are shared).
#[derive(Clone)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and type.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with.
    pub limits: wgpu::Limits,
    /// The first error wgpu raised outside an error scope (a rejected command buffer runs
    /// nothing), reported by the next [`GpuContext::wait`].
    error: std::sync::Arc<std::sync::Mutex<Option<String>>>,
}

impl GpuContext {
    /// Picks an adapter per `choice` and creates a device with the adapter's limits.
    pub fn new(choice: AdapterChoice) -> Result<Self, GpuError> {
        let adapters = enumerate_adapters();
        let seen = describe_all(&adapters);
        let adapter = pick(adapters, choice).ok_or(GpuError::NoAdapter {
            wanted: choice,
            seen,
        })?;
        Self::from_adapter(adapter)
    }

    /// A device on `adapter` with the adapter's own limits.
    pub fn from_adapter(adapter: wgpu::Adapter) -> Result<Self, GpuError> {
        let limits = adapter.limits();
        Self::from_adapter_with_limits(adapter, limits)
    }

    /// A device with `limits` (at most the adapter's): e.g. a stricter driver's limits on a
    /// lenient one, to test that what needs more is refused cleanly.
    pub fn from_adapter_with_limits(
        adapter: wgpu::Adapter,
        limits: wgpu::Limits,
    ) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        // Timestamps around each dispatch, for `bench`'s per-kernel times, where available.
        let timing =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        let features = adapter.features() & timing;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("fluxswarm"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device {
            adapter: describe(&info),
            message: e.to_string(),
        })?;
        let error = std::sync::Arc::new(std::sync::Mutex::new(None));
        let sink = error.clone();
        device.on_uncaptured_error(std::sync::Arc::new(move |e| {
            log::error!("wgpu: {e}");
            let mut first = sink.lock().unwrap_or_else(|p| p.into_inner());
            first.get_or_insert_with(|| e.to_string());
        }));
        Ok(Self {
            device,
            queue,
            info,
            limits,
            error,
        })
    }

    /// Whether the adapter is a software one (device type `Cpu`, e.g. lavapipe).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// e.g. `llvmpipe (LLVM 19.1.7, 256 bits) (Vulkan, Cpu)`.
    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    /// The line every command prints first.
    pub fn banner(&self) -> String {
        if self.is_software() {
            format!(
                "adapter: {} - software fallback, expect CPU speed",
                self.describe()
            )
        } else {
            format!("adapter: {}", self.describe())
        }
    }

    /// Waits for the submitted work; fails if wgpu rejected any command since the last check
    /// (its validation errors would otherwise leave results silently unwritten).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Operation(e.to_string()))?;
        let mut first = self.error.lock().unwrap_or_else(|p| p.into_inner());
        match first.take() {
            Some(e) => Err(GpuError::Rejected(e)),
            None => Ok(()),
        }
    }
}

/// Every adapter of every backend compiled in (or of those WGPU_BACKEND names).
pub fn enumerate_adapters() -> Vec<wgpu::Adapter> {
    // WGPU_BACKEND (e.g. `vulkan`, `gl`) narrows the backends searched (read here: wgpu's own
    // `with_env` needs its `std` feature, which the build leaves off).
    let backends = match std::env::var("WGPU_BACKEND") {
        Ok(list) if !list.trim().is_empty() => wgpu::Backends::from_comma_list(&list),
        _ => wgpu::Backends::all(),
    };
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    pollster::block_on(instance.enumerate_adapters(backends))
}

/// An adapter as name, driver, backend and device type, e.g. `llvmpipe (LLVM ...) (Vulkan, Cpu)`.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    let driver = if info.driver_info.is_empty() {
        String::new()
    } else {
        format!(" ({})", info.driver_info)
    };
    format!(
        "{}{} ({:?}, {:?})",
        info.name, driver, info.backend, info.device_type
    )
}

fn describe_all(adapters: &[wgpu::Adapter]) -> String {
    if adapters.is_empty() {
        return "none".into();
    }
    adapters
        .iter()
        .map(|a| describe(&a.get_info()))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Rank: real GPUs first (discrete, integrated, virtual), then CPU adapters; Vulkan before GL.
fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (kind, backend)
}

fn pick(adapters: Vec<wgpu::Adapter>, choice: AdapterChoice) -> Option<wgpu::Adapter> {
    adapters
        .into_iter()
        .filter(|a| {
            let cpu = a.get_info().device_type == wgpu::DeviceType::Cpu;
            match choice {
                AdapterChoice::Auto => true,
                AdapterChoice::Gpu => !cpu,
                AdapterChoice::Cpu => cpu,
            }
        })
        .min_by_key(|a| rank(&a.get_info()))
}
