//! Encoding of Allan-variance dispatches: each pass names its kernel, parameters and the windows
//! it reads and writes; [`submit`] binds them and records them all in one compute pass, in order
//! (wgpu puts a barrier between a dispatch that writes a buffer and the next that reads it).

use super::params::{OctaveParams, PrefixParams};
use crate::gpu::buffers::{bind_group, dispatch, Buf};
use crate::gpu::shaders::{Kernel, AVAR_ITEMS, WORKGROUP};
use crate::gpu::timing::{Stage, Stamp};
use crate::gpu::{GpuContext, GpuError};

/// Part of a buffer, as bound.
#[derive(Clone, Copy)]
pub(crate) struct View<'a> {
    pub buf: &'a Buf,
    pub offset: u64,
    pub size: u64,
}

impl<'a> View<'a> {
    pub(crate) fn whole(buf: &'a Buf) -> View<'a> {
        View {
            buf,
            offset: 0,
            size: buf.size(),
        }
    }

    fn binding(&self) -> wgpu::BindingResource<'a> {
        self.buf.range(self.offset, self.size)
    }
}

/// One dispatch.
pub(crate) enum Pass<'a> {
    /// A pyramid level (or part of one).
    Octave {
        params: OctaveParams,
        lo: View<'a>,
        hi: View<'a>,
        next: View<'a>,
        partials: View<'a>,
    },
    /// Prefix-sum second differences at one m (or part of them).
    Prefix {
        kernel: Kernel,
        params: PrefixParams,
        s: [View<'a>; 3],
        partials: View<'a>,
    },
}

/// Workgroups (hence partial sums) for `count` terms.
pub(crate) fn groups_for(count: usize) -> u32 {
    count.div_ceil((WORKGROUP * AVAR_ITEMS) as usize) as u32
}

impl Pass<'_> {
    fn kernel(&self) -> Kernel {
        match self {
            Pass::Octave { .. } => Kernel::AvarOctave,
            Pass::Prefix { kernel, .. } => *kernel,
        }
    }

    fn count(&self) -> u32 {
        match self {
            Pass::Octave { params, .. } => params.count,
            Pass::Prefix { params, .. } => params.count,
        }
    }
}

/// Buffers a submission reads that its caller does not own (the parameter blocks): to be held
/// until the results are read, so that the pool cannot hand them to another job before the
/// device has used them.
#[must_use = "hold until the submission's results are read"]
pub(crate) struct InFlight {
    _params: Vec<Buf>,
}

/// Records every pass in one compute pass and submits it.
pub(crate) fn submit(ctx: &GpuContext, passes: &[Pass<'_>]) -> Result<InFlight, GpuError> {
    if passes.is_empty() {
        return Ok(InFlight {
            _params: Vec::new(),
        });
    }
    // All parameter blocks in one uniform buffer, each at an aligned offset.
    let mut octave = Vec::new();
    let mut prefix = Vec::new();
    for pass in passes {
        match pass {
            Pass::Octave { params, .. } => octave.push(*params),
            Pass::Prefix { params, .. } => prefix.push(*params),
        }
    }
    let (octave_buf, octave_stride) = ctx.uniforms(&octave)?;
    let (prefix_buf, prefix_stride) = ctx.uniforms(&prefix)?;
    let octave_buf = Buf::from_lease(octave_buf);
    let prefix_buf = Buf::from_lease(prefix_buf);
    let params_size = std::mem::size_of::<OctaveParams>() as u64;
    debug_assert_eq!(params_size, std::mem::size_of::<PrefixParams>() as u64);

    let mut work = Vec::with_capacity(passes.len());
    let (mut io, mut ip) = (0u64, 0u64);
    for pass in passes {
        let pipeline = ctx.pipeline(pass.kernel())?;
        let group = match pass {
            Pass::Octave {
                lo,
                hi,
                next,
                partials,
                ..
            } => {
                let params = octave_buf.range(io * octave_stride, params_size);
                io += 1;
                bind_group(
                    ctx,
                    &pipeline,
                    &[
                        (0, params),
                        (1, lo.binding()),
                        (2, hi.binding()),
                        (3, next.binding()),
                        (4, partials.binding()),
                    ],
                )
            }
            Pass::Prefix { s, partials, .. } => {
                let params = prefix_buf.range(ip * prefix_stride, params_size);
                ip += 1;
                bind_group(
                    ctx,
                    &pipeline,
                    &[
                        (0, params),
                        (1, s[0].binding()),
                        (2, s[1].binding()),
                        (3, s[2].binding()),
                        (4, partials.binding()),
                    ],
                )
            }
        };
        work.push((pipeline, group, groups_for(pass.count() as usize)));
    }
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("allan variance"),
        });
    let stamp = ctx.stamp(Stage::Allan);
    {
        let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("allan variance"),
            timestamp_writes: stamp.as_ref().map(Stamp::writes),
        });
        for (pipeline, group, groups) in &work {
            dispatch(&mut cpass, pipeline, group, (*groups, 1));
        }
    }
    ctx.submit_timed(encoder, stamp)?;
    ctx.check()?;
    Ok(InFlight {
        _params: vec![octave_buf, prefix_buf],
    })
}
