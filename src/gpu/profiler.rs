//! Per-phase GPU timings.
//!
//! With `TIMESTAMP_QUERY` each compute pass gets a begin/end timestamp and
//! a phase's time is the sum of its passes' GPU durations. Without it the
//! phase is submitted on its own and timed on the wall clock around the
//! submission and a blocking device wait (so the figure includes submission
//! overhead). Either way the caller writes one closure per phase:
//!
//! ```ignore
//! profiler.phase("evaluate", |encoder, timestamps| {
//!     let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
//!         label: Some("mdas.halton.evaluate"),
//!         timestamp_writes: timestamps,
//!     });
//!     // set pipeline, bind groups, dispatch ...
//! })?;
//! let times = profiler.finish()?;
//! ```
//!
//! A name with a slash, "adaptive/count", is a part of phase "adaptive":
//! [`Profiler::finish`] folds the parts into their phase,
//! [`Profiler::finish_detailed`] keeps them apart too. Several phases can
//! share one submission ([`Profiler::batch`]).

use super::{Gpu, Readback};
use anyhow::Result;
use std::time::Instant;

/// Timestamp pairs per query set (a set holds 2 per pass).
const PAIRS_PER_SET: u32 = 128;

/// Named phase durations in milliseconds, in the order phases first ran.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhaseTimes(pub Vec<(String, f64)>);

impl PhaseTimes {
    pub fn add(&mut self, name: &str, ms: f64) {
        match self.0.iter_mut().find(|(n, _)| n == name) {
            Some((_, t)) => *t += ms,
            None => self.0.push((name.to_string(), ms)),
        }
    }

    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, t)| *t)
    }

    pub fn total(&self) -> f64 {
        self.0.iter().map(|(_, t)| t).sum()
    }

    /// The times with every part ("adaptive/count") added into its phase
    /// ("adaptive").
    pub fn folded(&self) -> PhaseTimes {
        let mut out = PhaseTimes::default();
        for (n, t) in &self.0 {
            out.add(n.split('/').next().unwrap_or(n), *t);
        }
        out
    }

    /// Adds every phase of `other` into `self`.
    pub fn merge(&mut self, other: &PhaseTimes) {
        for (n, t) in &other.0 {
            self.add(n, *t);
        }
    }
}

/// Where the times come from, for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    GpuTimestamps,
    WallClock,
}

impl Clock {
    /// As reports and EXR headers name it.
    pub fn name(self) -> &'static str {
        match self {
            Clock::GpuTimestamps => "gpu timestamps",
            Clock::WallClock => "wall clock",
        }
    }
}

pub struct Profiler<'g> {
    gpu: &'g Gpu,
    sets: Vec<wgpu::QuerySet>,
    /// Phase name of each timestamp pair, in query order.
    pairs: Vec<String>,
    wall: PhaseTimes,
}

impl<'g> Profiler<'g> {
    pub fn new(gpu: &'g Gpu) -> Self {
        Profiler {
            gpu,
            sets: Vec::new(),
            pairs: Vec::new(),
            wall: PhaseTimes::default(),
        }
    }

    pub fn clock(&self) -> Clock {
        if self.gpu.caps.timestamps {
            Clock::GpuTimestamps
        } else {
            Clock::WallClock
        }
    }

    /// Records one phase with `record` and submits it. `record` must pass
    /// the timestamp writes it is given to the one compute pass it begins.
    pub fn phase(
        &mut self,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder, Option<wgpu::ComputePassTimestampWrites<'_>>),
    ) -> Result<()> {
        let mut batch = self.batch(name);
        batch.phase(name, record)?;
        batch.submit();
        Ok(())
    }

    /// Adds a phase that ran on the host (wall clock, `ms`).
    pub fn wall_phase(&mut self, name: &str, ms: f64) {
        self.wall.add(name, ms);
    }

    /// Starts a batch of phases recorded into one command buffer and
    /// submitted together ([`Batch::submit`]), so the GPU runs them back
    /// to back with no host round trip between them.
    pub fn batch(&mut self, label: &str) -> Batch<'_, 'g> {
        let encoder = self.encoder(label);
        Batch {
            profiler: self,
            encoder,
        }
    }

    fn encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// The query slots of a new timestamp pair for phase `name`.
    fn next_pair(&mut self, name: &str) -> (&wgpu::QuerySet, u32) {
        let pair = self.pairs.len() as u32;
        if pair.is_multiple_of(PAIRS_PER_SET) {
            self.sets
                .push(self.gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("mdas.profiler.timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * PAIRS_PER_SET,
                }));
        }
        self.pairs.push(name.to_string());
        (self.sets.last().expect("just pushed"), pair % PAIRS_PER_SET)
    }

    /// Waits for all phases and returns their times, parts folded into
    /// their phases.
    pub fn finish(self) -> Result<PhaseTimes> {
        Ok(self.finish_detailed()?.folded())
    }

    /// Waits for all phases and returns their times as recorded, parts
    /// ("adaptive/count") apart.
    pub fn finish_detailed(self) -> Result<PhaseTimes> {
        let gpu = self.gpu;
        let mut times = self.wall;
        if self.pairs.is_empty() {
            return Ok(times);
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let mut readbacks = Vec::new();
        for (s, set) in self.sets.iter().enumerate() {
            let used = (self.pairs.len() as u32 - s as u32 * PAIRS_PER_SET).min(PAIRS_PER_SET);
            let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mdas.profiler.resolve"),
                size: 16 * used as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            encoder.resolve_query_set(set, 0..2 * used, &resolve, 0);
            let readback = Readback::<u64>::new(gpu, &resolve, 2 * used as usize)?;
            readback.record(&mut encoder);
            readbacks.push(readback);
        }
        gpu.queue.submit([encoder.finish()]);
        let ns_per_tick = gpu.queue.get_timestamp_period() as f64;
        let mut ticks = Vec::new();
        for r in readbacks {
            ticks.extend(r.finish(gpu)?);
        }
        for (i, name) in self.pairs.iter().enumerate() {
            let (begin, end) = (ticks[2 * i], ticks[2 * i + 1]);
            times.add(name, end.saturating_sub(begin) as f64 * ns_per_tick * 1e-6);
        }
        Ok(times)
    }
}

/// Phases recorded into one command buffer ([`Profiler::batch`]).
///
/// With timestamps each phase's compute pass gets its own pair and nothing
/// is submitted until [`Batch::submit`]. Without them a phase cannot be
/// timed inside a longer submission, so each [`Batch::phase`] submits what
/// the batch holds so far and waits (the wall clock then includes the
/// submission overhead, as for [`Profiler::phase`]).
pub struct Batch<'p, 'g> {
    profiler: &'p mut Profiler<'g>,
    encoder: wgpu::CommandEncoder,
}

impl Batch<'_, '_> {
    /// Records one phase; `record` must pass the timestamp writes it is
    /// given to the one compute pass it begins.
    pub fn phase(
        &mut self,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder, Option<wgpu::ComputePassTimestampWrites<'_>>),
    ) -> Result<()> {
        let gpu = self.profiler.gpu;
        if gpu.caps.timestamps {
            let (query_set, local) = self.profiler.next_pair(name);
            record(
                &mut self.encoder,
                Some(wgpu::ComputePassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: Some(2 * local),
                    end_of_pass_write_index: Some(2 * local + 1),
                }),
            );
        } else {
            let start = Instant::now();
            record(&mut self.encoder, None);
            let encoder = std::mem::replace(&mut self.encoder, self.profiler.encoder(name));
            gpu.queue.submit([encoder.finish()]);
            gpu.wait()?;
            self.profiler
                .wall
                .add(name, start.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// The batch's encoder, for commands outside any phase (copies,
    /// clears): they run in order with the phases.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        &mut self.encoder
    }

    /// Submits everything recorded since the last submission.
    pub fn submit(self) {
        self.profiler.gpu.queue.submit([self.encoder.finish()]);
    }
}

#[cfg(test)]
mod tests {
    use super::PhaseTimes;

    #[test]
    fn parts_fold_into_their_phase() {
        let mut t = PhaseTimes::default();
        t.add("evaluate", 1.0);
        t.add("adaptive/count", 2.0);
        t.add("adaptive/scan", 0.5);
        t.add("evaluate", 1.0);
        t.add("adaptive/count", 1.0);
        assert_eq!(t.get("adaptive/count"), Some(3.0));
        let f = t.folded();
        assert_eq!(
            f.0,
            vec![("evaluate".to_string(), 2.0), ("adaptive".to_string(), 3.5)]
        );
        assert_eq!(f.total(), t.total());
    }
}
