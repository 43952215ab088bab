//! Overlapping Allan variance (OADEV) on the GPU, for every channel of a recording in one
//! submission per group of channels (as many as fit the memory budget).
//!
//! - Octave taus (m = 2^k) come from the pairwise-mean pyramid: `M_1 = y − ȳ` (mean removed in f64
//!   on the CPU, then stored in f32), `M_2m[i] = (M_m[i] + M_m[i+m])/2`, and
//!   `σ²(mτ₀) = ½·mean_i (M_m[i+m] − M_m[i])²`, i = 0..=N−2m. One dispatch per level (per window,
//!   when chunked) computes the level's terms and the next level together; all levels of all
//!   channels are queued before anything is read. Levels are not fused into one dispatch: a level
//!   costs one read and one write of N values, which is already far below the cost of launching
//!   it on any real GPU, and fusing would add halo bookkeeping for nothing measurable.
//! - Other taus come from prefix sums (see the `prefix` module for the f64 and fixed-point
//!   schemes).
//! - Each workgroup reduces its terms to one partial sum; the host adds the partial sums in f64.
//!
//! EDF, noise identification and confidence intervals are the CPU module's (they need the
//! prefix sums, which are built on the CPU anyway): see `deviations`.

mod deviations;
mod paged;
mod params;
mod passes;
mod prefix;

pub(crate) use deviations::deviations;
pub use params::{OctaveParams, PrefixParams};

use std::sync::Arc;

use paged::Paged;
use passes::{groups_for, submit, Pass, View};
use prefix::{fixed_prefix, FixedPrefix};

use super::buffers::Buf;
use super::chunking::{spans, Caps, Paging};
use super::readback::read_buffer;
use super::shaders::Kernel;
use super::{GpuContext, GpuError};

/// One channel's data for [`oadev_variances`].
#[derive(Debug, Clone, Copy)]
pub struct ChannelData<'a> {
    /// Rate samples.
    pub y: &'a [f64],
    /// Their mean (removed before anything is stored in f32).
    pub mean: f64,
    /// S_t = Σ_{u<t}(y_u − mean), t = 0..=N, in f64 (`avar::PrefixSums::s`); used for non-octave
    /// taus on devices with f64.
    pub prefix: &'a [f64],
}

/// Overlapping Allan variance of each channel at averaging factors `ms` (each valid:
/// 1 ≤ m ≤ (N − 1)/2), in the order of `ms`.
pub fn oadev_variances(
    ctx: &Arc<GpuContext>,
    channels: &[ChannelData<'_>],
    ms: &[Vec<u64>],
) -> Result<Vec<Vec<f64>>, GpuError> {
    let caps = Caps::of(ctx);
    let mut out = Vec::with_capacity(channels.len());
    let mut start = 0;
    while start < channels.len() {
        // As many channels as fit the budget (at least one): 2 f32 levels + one 8-byte prefix
        // array per sample.
        let mut end = start + 1;
        let mut bytes = footprint(&channels[start], &ms[start]);
        while end < channels.len() {
            let more = footprint(&channels[end], &ms[end]);
            if bytes + more > caps.budget {
                break;
            }
            bytes += more;
            end += 1;
        }
        out.extend(group_variances(
            ctx,
            &caps,
            &channels[start..end],
            &ms[start..end],
        )?);
        start = end;
    }
    Ok(out)
}

fn footprint(ch: &ChannelData<'_>, ms: &[u64]) -> u64 {
    let n = ch.y.len() as u64;
    let octave = if ms.iter().any(|m| m.is_power_of_two()) {
        8 * n
    } else {
        0
    };
    let other = if ms.iter().any(|m| !m.is_power_of_two()) {
        8 * (n + 1)
    } else {
        0
    };
    octave + other
}

/// Device arrays of one channel.
struct Arrays {
    levels: Option<[Paged; 2]>,
    prefix: Option<(Paged, Kernel, f64, f32)>,
}

/// Where a tau's partial sums are, and how to turn their total into a variance.
struct Tally {
    channel: usize,
    tau: usize,
    /// (first, count) in the f32 or f64 partials.
    ranges: Vec<(usize, usize)>,
    wide: bool,
    /// Variance = total · factor.
    factor: f64,
}

/// Partial-sum slots, each dispatch's starting at a binding-aligned index.
struct Slots {
    align: usize,
    next: usize,
}

impl Slots {
    fn take(&mut self, count: usize) -> usize {
        let at = self.next;
        self.next = (at + count).next_multiple_of(self.align);
        at
    }
}

fn group_variances(
    ctx: &Arc<GpuContext>,
    caps: &Caps,
    channels: &[ChannelData<'_>],
    ms: &[Vec<u64>],
) -> Result<Vec<Vec<f64>>, GpuError> {
    let f32_paging = Paging::new(4, caps);
    let wide_paging = Paging::new(8, caps);
    let use_f64 = ctx.has_f64();

    // 1. Arrays, uploaded.
    let mut arrays = Vec::with_capacity(channels.len());
    for (ch, ms) in channels.iter().zip(ms) {
        let n = ch.y.len();
        let levels = if ms.iter().any(|m| m.is_power_of_two()) {
            let a = Paged::new(ctx, f32_paging, n)?;
            let b = Paged::new(ctx, f32_paging, n)?;
            a.upload_converted(ctx, ch.y, ch.mean);
            Some([a, b])
        } else {
            None
        };
        let prefix = if ms.iter().any(|m| !m.is_power_of_two()) {
            let s = Paged::new(ctx, wide_paging, n + 1)?;
            if use_f64 {
                s.upload(ctx, ch.prefix);
                Some((s, Kernel::AvarPrefixF64, 1.0, 1.0))
            } else {
                let FixedPrefix {
                    words,
                    amplitude,
                    scale,
                } = fixed_prefix(ch.y, ch.mean);
                s.upload(ctx, &words);
                Some((s, Kernel::AvarPrefixFixed, amplitude * amplitude, scale))
            }
        } else {
            None
        };
        arrays.push(Arrays { levels, prefix });
    }

    // 2. Dispatch layout: spans and partial-sum slots.
    let align32 = (caps.align / 4).max(1) as usize;
    let align64 = (caps.align / 8).max(1) as usize;
    let mut slots32 = Slots {
        align: align32,
        next: 0,
    };
    let mut slots64 = Slots {
        align: align64,
        next: 0,
    };
    let mut tallies = Vec::new();
    // (channel, step, first term, terms)
    let mut plan: Vec<(usize, Step, usize, usize)> = Vec::new();
    for (c, (ch, ms)) in channels.iter().zip(ms).enumerate() {
        let n = ch.y.len();
        let top = ms
            .iter()
            .filter(|m| m.is_power_of_two())
            .max()
            .map_or(0, |m| m.trailing_zeros() as usize + 1);
        for level in 0..top {
            let m = 1usize << level;
            let count = n + 1 - 2 * m;
            let tau = ms.iter().position(|&x| x == m as u64);
            let mut ranges = Vec::new();
            for span in spans(count, &[0, m], &f32_paging) {
                let groups = groups_for(span.len) as usize;
                let slot = slots32.take(groups);
                ranges.push((slot, groups));
                let last = level + 1 == top;
                plan.push((c, Step::Level { level, last, slot }, span.start, span.len));
            }
            if let Some(tau) = tau {
                tallies.push(Tally {
                    channel: c,
                    tau,
                    ranges,
                    wide: false,
                    factor: 0.5 / count as f64,
                });
            }
        }
        if let Some((_, kernel, amp2, _)) = &arrays[c].prefix {
            let wide = *kernel == Kernel::AvarPrefixF64;
            for (tau, &m) in ms.iter().enumerate() {
                if m.is_power_of_two() {
                    continue;
                }
                let m = m as usize;
                let count = n + 1 - 2 * m;
                let mut ranges = Vec::new();
                for span in spans(count, &[0, m, 2 * m], &wide_paging) {
                    let groups = groups_for(span.len) as usize;
                    let slot = if wide {
                        slots64.take(groups)
                    } else {
                        slots32.take(groups)
                    };
                    ranges.push((slot, groups));
                    plan.push((c, Step::Prefix { m, slot }, span.start, span.len));
                }
                let mf = m as f64;
                tallies.push(Tally {
                    channel: c,
                    tau,
                    ranges,
                    wide,
                    factor: amp2 / (2.0 * mf * mf * count as f64),
                });
            }
        }
    }

    // 3. Partial-sum buffers, passes, one submission.
    let partials32 = Buf::storage(ctx, (slots32.next.max(1) * 4) as u64)?;
    let partials64 = Buf::storage(ctx, (slots64.next.max(1) * 8) as u64)?;
    let mut passes = Vec::with_capacity(plan.len());
    for &(c, step, start, len) in &plan {
        let groups = groups_for(len) as u64;
        match step {
            Step::Level { level, last, slot } => {
                let [a, b] = arrays[c].levels.as_ref().expect("levels allocated");
                let (src, dst) = if level % 2 == 0 { (a, b) } else { (b, a) };
                let m = 1usize << level;
                let (lo, lo_off) = src.view(start, len);
                let (hi, hi_off) = src.view(start + m, len);
                let (next, next_off) = dst.view(start, len);
                passes.push(Pass::Octave {
                    params: OctaveParams {
                        count: len as u32,
                        lo_off,
                        hi_off,
                        next_off,
                        partial_base: 0,
                        write_next: u32::from(!last),
                        _pad0: 0,
                        _pad1: 0,
                    },
                    lo,
                    hi,
                    next,
                    partials: View {
                        buf: &partials32,
                        offset: slot as u64 * 4,
                        size: groups * 4,
                    },
                });
            }
            Step::Prefix { m, slot } => {
                let (s, kernel, _, scale) = arrays[c].prefix.as_ref().expect("prefix allocated");
                let (v0, o0) = s.view(start, len);
                let (v1, o1) = s.view(start + m, len);
                let (v2, o2) = s.view(start + 2 * m, len);
                let wide = *kernel == Kernel::AvarPrefixF64;
                let partials = if wide {
                    View {
                        buf: &partials64,
                        offset: slot as u64 * 8,
                        size: groups * 8,
                    }
                } else {
                    View {
                        buf: &partials32,
                        offset: slot as u64 * 4,
                        size: groups * 4,
                    }
                };
                passes.push(Pass::Prefix {
                    kernel: *kernel,
                    params: prefix::params(len, [o0, o1, o2], *scale),
                    s: [v0, v1, v2],
                    partials,
                });
            }
        }
    }
    let in_flight = submit(ctx, &passes)?;

    // 4. Read back, add in f64.
    let sums32: Vec<f32> = read_buffer(ctx, partials32.buffer(), 0, slots32.next)?;
    let sums64: Vec<f64> = read_buffer(ctx, partials64.buffer(), 0, slots64.next)?;
    drop(in_flight);
    let mut out: Vec<Vec<f64>> = ms.iter().map(|ms| vec![f64::NAN; ms.len()]).collect();
    for t in &tallies {
        let total: f64 = t
            .ranges
            .iter()
            .map(|&(first, count)| {
                if t.wide {
                    sums64[first..first + count].iter().sum::<f64>()
                } else {
                    sums32[first..first + count]
                        .iter()
                        .map(|&v| f64::from(v))
                        .sum::<f64>()
                }
            })
            .sum();
        out[t.channel][t.tau] = total * t.factor;
    }
    Ok(out)
}

/// One dispatch of the plan.
#[derive(Debug, Clone, Copy)]
enum Step {
    Level {
        level: usize,
        last: bool,
        slot: usize,
    },
    Prefix {
        m: usize,
        slot: usize,
    },
}

/// Input of [`run_prefix`]: the three windows' values.
pub(crate) enum PrefixData<'a> {
    F64([&'a [f64]; 3]),
    Fixed([&'a [[u32; 2]]; 3]),
}

/// One `avar_octave` dispatch on host data: (partial sums, next level).
pub(crate) fn run_octave_level(
    ctx: &Arc<GpuContext>,
    p: &OctaveParams,
    lo: &[f32],
    hi: &[f32],
) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
    let groups = groups_for(p.count as usize) as usize;
    let lo_buf = Buf::with_data(ctx, lo)?;
    let hi_buf = Buf::with_data(ctx, hi)?;
    let next_len = (p.next_off + p.count) as usize;
    let next = Buf::storage(ctx, next_len as u64 * 4)?;
    let partials = Buf::storage(ctx, (groups.max(1) * 4) as u64)?;
    let in_flight = submit(
        ctx,
        &[Pass::Octave {
            params: *p,
            lo: View::whole(&lo_buf),
            hi: View::whole(&hi_buf),
            next: View::whole(&next),
            partials: View::whole(&partials),
        }],
    )?;
    let sums = read_buffer(ctx, partials.buffer(), 0, groups)?;
    let next = read_buffer(ctx, next.buffer(), 0, next_len)?;
    drop(in_flight);
    Ok((sums, next))
}

/// One `avar_prefix_f64` or `avar_prefix_fixed` dispatch on host data: the partial sums' bytes.
pub(crate) fn run_prefix(
    ctx: &Arc<GpuContext>,
    p: &PrefixParams,
    data: PrefixData<'_>,
) -> Result<Vec<u8>, GpuError> {
    let groups = groups_for(p.count as usize) as usize;
    let (kernel, bufs, elem) = match data {
        PrefixData::F64(s) => (
            Kernel::AvarPrefixF64,
            [
                Buf::with_data(ctx, s[0])?,
                Buf::with_data(ctx, s[1])?,
                Buf::with_data(ctx, s[2])?,
            ],
            8,
        ),
        PrefixData::Fixed(s) => (
            Kernel::AvarPrefixFixed,
            [
                Buf::with_data(ctx, s[0])?,
                Buf::with_data(ctx, s[1])?,
                Buf::with_data(ctx, s[2])?,
            ],
            4,
        ),
    };
    let partials = Buf::storage(ctx, (groups.max(1) * elem) as u64)?;
    let in_flight = submit(
        ctx,
        &[Pass::Prefix {
            kernel,
            params: *p,
            s: [
                View::whole(&bufs[0]),
                View::whole(&bufs[1]),
                View::whole(&bufs[2]),
            ],
            partials: View::whole(&partials),
        }],
    )?;
    let out = read_buffer(ctx, partials.buffer(), 0, groups * elem);
    drop(in_flight);
    out
}
