//! Primary sample space (Kelemen et al. 2002): the state of a Metropolis chain as the vector
//! of uniform numbers a path tracer would have drawn, and its mutations (pbrt-v4's
//! `MLTSampler`).
//!
//! A [`Sampler`](crate::Sampler) made with [`Sampler::primary`](crate::Sampler::primary)
//! hands these numbers to unchanged integrator code. Numbers are split into streams (one per
//! subpath for `mmlt`), each read from its start after [`PrimarySamples::start_stream`], so a
//! subpath that draws more numbers does not shift the other's.
//!
//! Mutations are lazy: a number is only moved when it is read, by every small step it missed
//! at once (a Gaussian of `sigma * sqrt(steps)`, wrapped onto `[0, 1)`), or replaced by a
//! fresh one after a large step. A rejected proposal restores the numbers it touched.
//! Everything is drawn from the chain's own generator, so a chain is a function of its seed.

use crate::random::unit_f32;
use rand::rngs::SmallRng;

/// One number of the state, with what a rejection restores.
#[derive(Clone, Copy, Debug, Default)]
struct PrimarySample {
    value: f32,
    /// The iteration that last changed it.
    modified: u64,
    backup: f32,
    backup_modified: u64,
}

/// A Metropolis chain's state in primary sample space.
pub struct PrimarySamples {
    x: Vec<PrimarySample>,
    rng: SmallRng,
    sigma: f32,
    large_step_probability: f32,
    streams: u32,
    /// Proposals made so far (accepted ones and the one in progress).
    iteration: u64,
    /// Whether the proposal in progress is a large step (every number fresh).
    large_step: bool,
    /// The iteration of the last accepted large step.
    last_large_step: u64,
    /// The stream being read, and the next index within it.
    stream: u32,
    index: u32,
}

impl PrimarySamples {
    /// A state whose first evaluation reads fresh uniform numbers from `rng` (as a path
    /// tracer's sample would), with small steps of standard deviation `sigma`, large steps of
    /// probability `large_step_probability`, and `streams` streams.
    pub fn new(rng: SmallRng, sigma: f32, large_step_probability: f32, streams: u32) -> Self {
        PrimarySamples {
            x: Vec::new(),
            rng,
            sigma,
            large_step_probability,
            streams: streams.max(1),
            iteration: 0,
            large_step: true,
            last_large_step: 0,
            stream: 0,
            index: 0,
        }
    }

    /// Starts over from fresh numbers drawn from `rng`, keeping the memory.
    pub fn restart(&mut self, rng: SmallRng) {
        self.x.clear();
        self.rng = rng;
        self.iteration = 0;
        self.large_step = true;
        self.last_large_step = 0;
        self.stream = 0;
        self.index = 0;
    }

    /// Continues the chain with numbers from `rng` (so that chains which start from the same
    /// state go different ways).
    pub fn reseed(&mut self, rng: SmallRng) {
        self.rng = rng;
    }

    /// Starts a proposal: a large step with its probability, otherwise a small one.
    pub fn start_iteration(&mut self) {
        self.iteration += 1;
        self.large_step = unit_f32(&mut self.rng) < self.large_step_probability;
        self.stream = 0;
        self.index = 0;
    }

    /// Whether the proposal in progress is a large step.
    pub fn is_large_step(&self) -> bool {
        self.large_step
    }

    /// Keeps the proposal as the new state.
    pub fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
        }
    }

    /// Returns to the state before the proposal.
    pub fn reject(&mut self) {
        for x in &mut self.x {
            if x.modified == self.iteration {
                x.value = x.backup;
                x.modified = x.backup_modified;
            }
        }
        self.iteration = self.iteration.saturating_sub(1);
    }

    /// Reads stream `stream` from its first number on.
    pub fn start_stream(&mut self, stream: u32) {
        self.stream = stream.min(self.streams - 1);
        self.index = 0;
    }

    /// The next number of the current stream, mutated as the proposal asks.
    pub fn next_1d(&mut self) -> f32 {
        let i = self.index as usize * self.streams as usize + self.stream as usize;
        self.index += 1;
        if i >= self.x.len() {
            // Numbers no evaluation has read yet are fresh uniform ones.
            let start = self.x.len();
            self.x.resize(i + 1, PrimarySample::default());
            for x in &mut self.x[start..] {
                x.value = unit_f32(&mut self.rng);
                x.modified = self.iteration;
                x.backup = x.value;
                x.backup_modified = x.modified;
            }
        }
        self.ensure_ready(i);
        self.x[i].value
    }

    /// Brings number `i` up to the proposal in progress.
    fn ensure_ready(&mut self, i: usize) {
        let x = &mut self.x[i];
        // Already moved by this proposal, or drawn fresh by it.
        if x.modified >= self.iteration {
            return;
        }
        // Untouched since before the last accepted large step: that step replaced it.
        if x.modified < self.last_large_step {
            x.value = unit_f32(&mut self.rng);
            x.modified = self.last_large_step;
        }
        x.backup = x.value;
        x.backup_modified = x.modified;
        if self.large_step {
            x.value = unit_f32(&mut self.rng);
        } else {
            // Every small step it missed, at once: their sum is one Gaussian.
            let steps = self.iteration - x.modified;
            let sd = self.sigma * (steps as f32).sqrt();
            x.value = wrap(x.value + standard_normal(&mut self.rng) * sd);
        }
        x.modified = self.iteration;
    }
}

/// `v` wrapped onto `[0, 1)`.
fn wrap(v: f32) -> f32 {
    let w = v - v.floor();
    // A tiny negative value rounds to 1.0: its neighbour on the torus is 0.
    if (0.0..1.0).contains(&w) {
        w
    } else {
        0.0
    }
}

/// A standard normal number (Box-Muller).
fn standard_normal(rng: &mut SmallRng) -> f32 {
    let u1 = 1.0 - unit_f32(rng);
    let u2 = unit_f32(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::keyed_rng;
    use crate::testing::chi2::assert_chi2_discrete;

    fn read(p: &mut PrimarySamples, n: usize) -> Vec<f32> {
        (0..n).map(|_| p.next_1d()).collect()
    }

    #[test]
    fn a_rejected_proposal_restores_every_number_it_moved() {
        let mut p = PrimarySamples::new(keyed_rng(1, 2), 0.01, 0.3, 2);
        p.start_stream(0);
        let a0 = read(&mut p, 5);
        p.start_stream(1);
        let b0 = read(&mut p, 3);
        for _ in 0..20 {
            p.start_iteration();
            p.start_stream(0);
            let a = read(&mut p, 7);
            p.start_stream(1);
            let b = read(&mut p, 3);
            assert!(a.iter().all(|v| (0.0..1.0).contains(v)));
            assert_ne!((&a[..5], &b[..]), (&a0[..], &b0[..]));
            p.reject();
        }
        // Read back after the rejections: the first state, whatever the proposals read.
        p.start_iteration();
        p.reject();
        p.start_stream(0);
        assert_eq!(&read(&mut p, 5)[..], &a0[..]);
    }

    #[test]
    fn streams_do_not_shift_each_other() {
        // A stream's k-th number has its own place in the state, whatever the other streams
        // read: a subpath that grows longer leaves the other subpath's numbers where they were.
        let mut p = PrimarySamples::new(keyed_rng(3, 4), 0.01, 0.3, 3);
        p.start_stream(0);
        read(&mut p, 3);
        p.start_stream(1);
        let first = read(&mut p, 2);
        // The same state read again, stream 0 now reading five numbers (two new ones).
        p.start_stream(0);
        let longer = read(&mut p, 5);
        p.start_stream(1);
        assert_eq!(read(&mut p, 2), first);
        assert!(longer.iter().all(|v| (0.0..1.0).contains(v)));
        // Reading the streams in the other order changes nothing either.
        p.start_stream(1);
        assert_eq!(read(&mut p, 2), first);
        p.start_stream(0);
        assert_eq!(read(&mut p, 5), longer);
    }

    #[test]
    fn chi2_small_steps_keep_numbers_uniform() {
        // The mutation is symmetric on the torus, so the uniform distribution is stationary:
        // independent chains started uniform and moved by accepted small steps stay uniform
        // (chi-square on 20 cells; wrapping or a skewed Gaussian would show).
        let cells = 20;
        let samples = 100_000;
        let mut observed = vec![0u64; cells];
        for k in 0..samples {
            let mut p = PrimarySamples::new(keyed_rng(5, k as u64), 0.3, 0.0, 1);
            read(&mut p, 1);
            for _ in 0..4 {
                p.start_iteration();
                p.next_1d();
                p.accept();
            }
            p.start_iteration();
            let v = p.next_1d();
            observed[((v * cells as f32) as usize).min(cells - 1)] += 1;
        }
        let expected = vec![samples as f64 / cells as f64; cells];
        let _ = assert_chi2_discrete("primary sample mutation", &observed, &expected, samples);
    }

    #[test]
    fn a_large_step_replaces_numbers_lazily() {
        let mut p = PrimarySamples::new(keyed_rng(7, 8), 0.01, 1.0, 1);
        let first = read(&mut p, 3);
        p.start_iteration();
        assert!(p.is_large_step());
        let one = p.next_1d();
        p.accept();
        assert_ne!(one, first[0]);
        // The numbers the large step did not read are fresh when read later.
        p.start_iteration();
        p.reject();
        let _ = p.next_1d();
        let later = read(&mut p, 2);
        assert_ne!(later, first[1..].to_vec());
        assert!(later.iter().all(|v| (0.0..1.0).contains(v)));
    }
}
