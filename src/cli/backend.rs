//! The estimation backend a command asked for, chosen one way for `analyze`, `psd`, `avar` and
//! `screen`: `auto` takes a real GPU when there is one and the CPU otherwise (a software
//! rasteriser such as lavapipe is slower than the CPU path); `gpu` takes whatever adapter opens.

use std::sync::Arc;

use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::{
    probe_quietly, request_adapter, ContextOptions, GpuBackend, GpuContext, GpuError,
};

use super::config::BackendChoice;

/// How much the choice may say on stderr.
#[derive(Clone, Copy, Debug)]
pub struct Chatter {
    /// Show the graphics stack's own messages during the probe and the reason a GPU failed.
    pub verbose: bool,
    /// Say nothing about falling back to the CPU.
    pub quiet: bool,
}

/// Opens the preferred GPU. Unless `verbose`, the graphics stack's own messages during the probe
/// (Mesa's "XDG_RUNTIME_DIR is invalid", loader warnings) are hidden; the error, if any, is
/// returned and printed by the caller once stderr is back.
fn open_gpu(verbose: bool) -> Result<GpuBackend, GpuError> {
    let options = ContextOptions {
        quiet_probe: !verbose,
        ..ContextOptions::default()
    };
    Ok(GpuBackend::with_context(Arc::new(
        GpuContext::with_options(&options)?,
    )))
}

/// What `auto` found.
enum Probe {
    Hardware(GpuBackend),
    /// A software rasteriser, by name: no device is opened on it.
    Software(String),
}

/// The preferred adapter, and a device on it only when it is real hardware: opening a device on
/// lavapipe was wasted work for `auto`, which computes on the CPU then (a tenth of a small file's
/// `avar`). Quiet as [`open_gpu`].
fn open_hardware_gpu(verbose: bool) -> Result<Probe, GpuError> {
    let options = ContextOptions {
        quiet_probe: !verbose,
        ..ContextOptions::default()
    };
    probe_quietly(options.quiet_probe, || {
        let adapter = request_adapter(&options)?;
        let info = adapter.get_info();
        if info.device_type == wgpu::DeviceType::Cpu {
            return Ok(Probe::Software(info.name));
        }
        let context = GpuContext::on_adapter(&adapter, &options)?;
        Ok(Probe::Hardware(GpuBackend::with_context(Arc::new(context))))
    })
}

/// The backend for `choice`. An error only for `gpu`, which must not fall back.
pub fn choose(choice: BackendChoice, chatter: Chatter) -> Result<Box<dyn Backend>, GpuError> {
    match choice {
        BackendChoice::Cpu => Ok(Box::new(CpuBackend)),
        BackendChoice::Gpu => Ok(Box::new(open_gpu(chatter.verbose)?)),
        BackendChoice::Auto => match open_hardware_gpu(chatter.verbose) {
            Ok(Probe::Hardware(gpu)) => Ok(Box::new(gpu)),
            Ok(Probe::Software(name)) => {
                if !chatter.quiet {
                    eprintln!(
                        "imunoise: only a software GPU ({name}); computing on the CPU (--backend gpu forces it)"
                    );
                }
                Ok(Box::new(CpuBackend))
            }
            Err(e) => {
                if chatter.verbose {
                    eprintln!("imunoise: no usable GPU ({e}); computing on the CPU");
                } else if !chatter.quiet {
                    eprintln!("imunoise: no usable GPU; computing on the CPU (-v says why)");
                }
                Ok(Box::new(CpuBackend))
            }
        },
    }
}

/// The line printed when `--backend gpu` cannot open one.
pub fn gpu_failure(e: &GpuError, verbose: bool) -> String {
    let hint = if verbose {
        ""
    } else {
        " (-v shows what the graphics drivers say)"
    };
    format!("--backend gpu: {e}{hint}")
}
