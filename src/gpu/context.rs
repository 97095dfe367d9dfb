//! Adapter selection and the device of the GPU backend: which backend a run
//! uses (`auto | cpu | gpu`, `CGFEM_BACKEND`), which adapter (a name filter,
//! `CGFEM_ADAPTER`), at which precision (f64 where the adapter has
//! `SHADER_F64`, else f32 inside defect correction), and the device opened
//! with the adapter's own limits (storage binding and buffer sizes). The
//! binding size that kernels split their arrays by ([`super::windows`]) may
//! be lowered with `CGFEM_MAX_BINDING_BYTES` (to exercise the splitting on
//! small problems).

use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};

use super::kernels::Pipelines;
use super::windows::BindingLimits;

/// Environment variable lowering the storage binding size the kernels assume.
pub const MAX_BINDING_ENV: &str = "CGFEM_MAX_BINDING_BYTES";

/// Which backend a run asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The GPU when an adapter is found, else the CPU (with a notice).
    #[default]
    Auto,
    Cpu,
    /// The GPU or an error ([`Error::NoAdapter`], exit code 2).
    Gpu,
}

impl FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(BackendChoice::Auto),
            "cpu" => Ok(BackendChoice::Cpu),
            "gpu" => Ok(BackendChoice::Gpu),
            other => Err(format!("unknown backend '{other}' (auto, cpu, gpu)")),
        }
    }
}

impl BackendChoice {
    /// `given`, else `CGFEM_BACKEND`, else `auto`.
    pub fn resolve(given: Option<BackendChoice>) -> Result<BackendChoice> {
        match (given, std::env::var("CGFEM_BACKEND")) {
            (Some(b), _) => Ok(b),
            (None, Ok(v)) => v.parse().map_err(|reason| Error::CaseFile {
                file: "(environment)".into(),
                key: "CGFEM_BACKEND".into(),
                reason,
            }),
            (None, Err(_)) => Ok(BackendChoice::Auto),
        }
    }
}

/// Floating-point type of the device vectors and kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    /// `"f32"` or `"f64"`, as in reports.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }

    /// Bytes per entry.
    pub fn bytes(self) -> u64 {
        match self {
            Precision::F32 => 4,
            Precision::F64 => 8,
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The precision a run asks for: `auto` is f64 where the adapter supports it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PrecisionChoice {
    #[default]
    Auto,
    F32,
    F64,
}

impl FromStr for PrecisionChoice {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(PrecisionChoice::Auto),
            "f32" => Ok(PrecisionChoice::F32),
            "f64" => Ok(PrecisionChoice::F64),
            other => Err(format!("unknown precision '{other}' (auto, f32, f64)")),
        }
    }
}

/// What `cgfem-gpu info` prints about an adapter.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub f64: bool,
    pub subgroups: bool,
    pub subgroup_sizes: (u32, u32),
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
    pub max_compute_workgroups_per_dimension: u32,
    pub max_storage_buffers_per_shader_stage: u32,
}

impl AdapterSummary {
    fn of(adapter: &wgpu::Adapter) -> Self {
        let info = adapter.get_info();
        let features = adapter.features();
        let limits = adapter.limits();
        AdapterSummary {
            name: info.name,
            backend: format!("{:?}", info.backend).to_lowercase(),
            device_type: format!("{:?}", info.device_type),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_string(),
            f64: features.contains(wgpu::Features::SHADER_F64),
            subgroups: features.contains(wgpu::Features::SUBGROUP),
            subgroup_sizes: (info.subgroup_min_size, info.subgroup_max_size),
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
            max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
            max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
        }
    }
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        write!(
            f,
            "{} [{}, {}] driver: {}; f64: {}; subgroups: {} ({}..{}); \
             max storage binding {:.0} MiB, max buffer {:.0} MiB, \
             {} workgroups per dimension, {} storage buffers per stage",
            self.name,
            self.backend,
            self.device_type,
            self.driver,
            if self.f64 { "yes" } else { "no" },
            if self.subgroups { "yes" } else { "no" },
            self.subgroup_sizes.0,
            self.subgroup_sizes.1,
            mib(self.max_storage_buffer_binding_size),
            mib(self.max_buffer_size),
            self.max_compute_workgroups_per_dimension,
            self.max_storage_buffers_per_shader_stage,
        )
    }
}

/// The adapters of wgpu's primary backends: Vulkan, Metal and DX12 (each
/// compiled only where the platform has it). GL is left out: it has neither
/// f64 nor the storage-buffer counts the apply kernel binds.
fn adapters() -> Vec<wgpu::Adapter> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::PRIMARY;
    let instance = wgpu::Instance::new(desc);
    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY))
}

/// Every adapter the instance sees.
pub fn list_adapters() -> Vec<AdapterSummary> {
    adapters().iter().map(AdapterSummary::of).collect()
}

/// `given`, else `CGFEM_ADAPTER`, else none.
pub fn adapter_filter(given: Option<&str>) -> Option<String> {
    given
        .map(str::to_string)
        .or_else(|| std::env::var("CGFEM_ADAPTER").ok())
        .filter(|s| !s.is_empty())
}

/// Rank of a device type: discrete GPUs first, software rasterisers last.
fn preference(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// An opened device with its compiled kernels.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub precision: Precision,
    pub limits: wgpu::Limits,
    /// The binding size and offset alignment the kernels' windows use.
    pub bindings: BindingLimits,
    pub(crate) pipelines: Pipelines,
}

/// The adapter's binding limits, with the binding size lowered to `lowered`
/// (the value of `CGFEM_MAX_BINDING_BYTES`) when given (never below
/// [`BindingLimits::smallest`], never above the adapter's).
pub(super) fn binding_limits(
    limits: &wgpu::Limits,
    lowered: Option<&str>,
) -> Result<BindingLimits> {
    let adapter = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let max_bytes = match lowered {
        Some(v) => v
            .trim()
            .parse::<u64>()
            .map_err(|e| Error::CaseFile {
                file: "(environment)".into(),
                key: MAX_BINDING_ENV.into(),
                reason: format!("'{v}' is not a number of bytes: {e}"),
            })?
            .clamp(BindingLimits::smallest(), adapter),
        None => adapter,
    };
    Ok(BindingLimits {
        max_bytes,
        align: limits.min_storage_buffer_offset_alignment as u64,
    })
}

impl GpuContext {
    /// Opens the preferred adapter whose name contains `filter` (case
    /// insensitive), at the precision asked for. [`Error::NoAdapter`] when none
    /// matches or f64 is asked of an adapter without it.
    pub fn new(filter: Option<&str>, precision: PrecisionChoice) -> Result<GpuContext> {
        Self::open(filter, precision, true)
    }

    /// [`GpuContext::new`] among the hardware adapters only: a software
    /// rasteriser (wgpu device type `Cpu`: lavapipe, llvmpipe, SwiftShader)
    /// runs the kernels on the CPU cores, slower than the native CPU backend,
    /// so `--backend auto` never picks one ([`Error::NoAdapter`] instead).
    pub fn new_hardware(filter: Option<&str>, precision: PrecisionChoice) -> Result<GpuContext> {
        Self::open(filter, precision, false)
    }

    fn open(
        filter: Option<&str>,
        precision: PrecisionChoice,
        software: bool,
    ) -> Result<GpuContext> {
        let wanted = filter.map(str::to_lowercase);
        let mut candidates: Vec<wgpu::Adapter> = adapters()
            .into_iter()
            .filter(|a| software || a.get_info().device_type != wgpu::DeviceType::Cpu)
            .filter(|a| match &wanted {
                Some(w) => a.get_info().name.to_lowercase().contains(w),
                None => true,
            })
            .filter(|a| {
                precision != PrecisionChoice::F64
                    || a.features().contains(wgpu::Features::SHADER_F64)
            })
            .collect();
        candidates.sort_by_key(|a| preference(a.get_info().device_type));
        let Some(adapter) = candidates.into_iter().next() else {
            let mut wanted = filter.map_or("any adapter".to_string(), |f| format!("'{f}'"));
            if !software {
                wanted = format!("{wanted} that is not a software rasteriser");
            }
            if precision == PrecisionChoice::F64 {
                wanted.push_str(" with SHADER_F64");
            }
            let seen: Vec<String> = list_adapters().into_iter().map(|a| a.name).collect();
            return Err(Error::NoAdapter {
                wanted,
                found: if seen.is_empty() {
                    "none".into()
                } else {
                    seen.join(", ")
                },
            });
        };
        let summary = AdapterSummary::of(&adapter);
        let precision = match precision {
            PrecisionChoice::F32 => Precision::F32,
            _ if summary.f64 => Precision::F64,
            _ => Precision::F32,
        };
        let required_features = if precision == Precision::F64 {
            wgpu::Features::SHADER_F64
        } else {
            wgpu::Features::empty()
        };
        let limits = adapter.limits();
        let bindings = binding_limits(&limits, std::env::var(MAX_BINDING_ENV).ok().as_deref())?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("cgfem-gpu"),
            required_features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu {
            what: format!("opening {}: {e}", summary.name),
        })?;
        let pipelines = Pipelines::new(&device, precision);
        Ok(GpuContext {
            device,
            queue,
            adapter: summary,
            precision,
            limits,
            bindings,
            pipelines,
        })
    }

    /// Can a buffer of `bytes` bytes (`what`) live on this device? Arrays
    /// beyond one storage binding are bound in windows, but one buffer holds
    /// at most `max_buffer_size` bytes: [`Error::DeviceTooSmall`] (exit code
    /// 2) naming both sizes when not.
    pub fn check_buffer(&self, what: &str, bytes: u64) -> Result<()> {
        let max = self.limits.max_buffer_size;
        if bytes > max {
            return Err(Error::DeviceTooSmall {
                what: format!(
                    "{what} of {bytes} bytes exceeds the largest buffer of {} ({max} bytes); \
                     use a lower level or --backend cpu",
                    self.adapter.name
                ),
            });
        }
        Ok(())
    }

    /// [`GpuContext::check_buffer`] for a vector of `n` entries.
    pub fn check_vector_len(&self, n: usize) -> Result<()> {
        let what = format!("a vector of {n} dofs at {}", self.precision.name());
        self.check_buffer(&what, n as u64 * self.precision.bytes())
    }

    /// Entries of the context's precision in one storage binding.
    pub fn max_binding_entries(&self) -> u64 {
        self.bindings.max_bytes / self.precision.bytes()
    }
}
