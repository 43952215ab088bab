//! The per-segment kernel: detrend and window into the FFT input, real FFT, |X_k|².
//!
//! A worker owns its buffers (FFT input, spectrum, FFT scratch) and reuses them for every segment it
//! processes, so the steady state allocates nothing. One worker per thread.

use realfft::num_complex::Complex;

use super::WelchPlan;

/// Scratch buffers for one thread.
pub(crate) struct SegmentWorker {
    input: Vec<f64>,
    spectrum: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl SegmentWorker {
    pub(crate) fn new(plan: &WelchPlan) -> Self {
        let fft = plan.fft();
        SegmentWorker {
            input: fft.make_input_vec(),
            spectrum: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
        }
    }

    /// Transforms the segment `head ++ tail` (nperseg samples in all) and returns its spectrum
    /// X_k, k = 0..=nfft/2.
    fn transform(&mut self, plan: &WelchPlan, head: &[f64], tail: &[f64]) -> &[Complex<f64>] {
        let n = plan.nperseg();
        plan.config()
            .detrend
            .apply_windowed(head, tail, plan.window(), &mut self.input);
        // realfft uses its input as scratch: the zero padding has to be written every time.
        self.input[n..].fill(0.0);
        // The buffers were made by this plan's FFT, so the lengths always match.
        plan.fft()
            .process_with_scratch(&mut self.input, &mut self.spectrum, &mut self.scratch)
            .expect("buffers sized by the FFT plan");
        &self.spectrum
    }

    /// Adds |X_k|² of the segment `head ++ tail` to `acc` (length nfft/2 + 1).
    pub(crate) fn accumulate(
        &mut self,
        plan: &WelchPlan,
        head: &[f64],
        tail: &[f64],
        acc: &mut [f64],
    ) {
        let spectrum = self.transform(plan, head, tail);
        for (a, x) in acc.iter_mut().zip(spectrum) {
            *a += x.re * x.re + x.im * x.im;
        }
    }

    /// Writes |X_k|² of the segment `head ++ tail` into `row` (length nfft/2 + 1), for median
    /// averaging, which keeps every segment.
    pub(crate) fn power_into(
        &mut self,
        plan: &WelchPlan,
        head: &[f64],
        tail: &[f64],
        row: &mut [f64],
    ) {
        let spectrum = self.transform(plan, head, tail);
        for (r, x) in row.iter_mut().zip(spectrum) {
            *r = x.re * x.re + x.im * x.im;
        }
    }
}
