//! Where a substep's time goes on the GPU, stage by stage: timestamps
//! written between the stages of one substep (`wgpu::Features`
//! `TIMESTAMP_QUERY` and `TIMESTAMP_QUERY_INSIDE_ENCODERS`, where the
//! adapter has them), read back after it. `firn bench --backend gpu
//! --phases` prints them; docs/gpu.md ("Bytes per kernel") sets each
//! stage against the bytes it must move.
//!
//! The timed substeps run one per submission, so they cost a round trip
//! each that the batches of a run do not; the stages' times are what the
//! GPU spent between the marks.

use super::GpuSnow;
use super::is_implicit;
use crate::buffers::read_back;
use crate::context::{GpuContext, TIMESTAMPS};
use crate::error::GpuError;

/// The stages timed, in substep order.
pub const STAGE_NAMES: [&str; STAGES] = [
    "blocks",
    "begin_step",
    "clear",
    "binning",
    "scatter",
    "grid_update",
    "gather",
    "spindrift",
];

/// Number of stages timed.
pub const STAGES: usize = 8;

/// The marks between the stages: the start, then the end of each stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Before the first stage.
    Start,
    /// The sparse grid's block table.
    Blocks,
    /// Δt and the stop conditions.
    BeginStep,
    /// The grid's word planes cleared.
    Clear,
    /// The counting sort of the binned scatter (nothing with the atomic one).
    Binning,
    /// Particle to grid.
    Scatter,
    /// The grid update.
    GridUpdate,
    /// Grid to particle.
    Gather,
    /// Spindrift (nothing without it).
    Spindrift,
}

/// Timestamp queries for the marks of one substep.
pub struct StageClock {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
}

impl StageClock {
    /// The clock, where `context`'s device has timestamps.
    pub fn new(context: &GpuContext) -> Option<StageClock> {
        if !context.device.features().contains(TIMESTAMPS) {
            return None;
        }
        let count = STAGES as u32 + 1;
        Some(StageClock {
            queries: context.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage times"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolved: context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("stage times resolved"),
                size: u64::from(count) * wgpu::QUERY_SIZE as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            period: f64::from(context.queue.get_timestamp_period()),
        })
    }

    /// Records the timestamp of `stage`'s mark.
    fn mark(&self, encoder: &mut wgpu::CommandEncoder, stage: Stage) {
        encoder.write_timestamp(&self.queries, stage as u32);
    }

    /// Records the resolve of the marks, after the substep.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..STAGES as u32 + 1, &self.resolved, 0);
    }

    /// Each stage's seconds, from the marks resolved last.
    pub fn read(&self, context: &GpuContext) -> Result<[f64; STAGES], GpuError> {
        let ticks = read_back::<u64>(context, &[(&self.resolved, STAGES + 1)])?.remove(0);
        Ok(std::array::from_fn(|stage| {
            ticks[stage + 1].saturating_sub(ticks[stage]) as f64 * self.period * 1e-9
        }))
    }
}

/// Marks the end of `stage` on `clock`, if there is one.
pub fn mark(clock: Option<&StageClock>, encoder: &mut wgpu::CommandEncoder, stage: Stage) {
    if let Some(clock) = clock {
        clock.mark(encoder, stage);
    }
}

/// The seconds each stage took over some substeps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Seconds per stage, in [`STAGE_NAMES`] order, summed.
    pub seconds: [f64; STAGES],
    /// Substeps timed.
    pub substeps: u32,
}

impl GpuSnow {
    /// Runs the substeps up to simulated time `until`, at most `limit` of
    /// them, one per submission, timing each stage. `None` where the
    /// adapter has no timestamps, with the semi-implicit integrator (whose
    /// solve is submitted in parts) and with rigid bodies (whose host side
    /// runs between substeps).
    pub fn stage_times(&mut self, until: f64, limit: u32) -> Result<Option<StageTimes>, GpuError> {
        let clock = match StageClock::new(&self.context) {
            Some(clock) if !is_implicit(&self.scene) && self.scene.rigid_bodies.is_empty() => clock,
            _ => return Ok(None),
        };
        self.begin_frame(until);
        let mut times = StageTimes::default();
        while times.substeps < limit {
            let before = self.last.steps;
            let (state, seconds) = self
                .substep
                .run_timed(&self.context, &self.buffers, &clock)?;
            self.last = state;
            self.check_trouble(&state)?;
            if self.serve_wait(&state)? {
                continue;
            }
            if state.steps == before {
                // The frame was done, as a batch ends one.
                self.time = until;
                break;
            }
            self.steps += 1;
            self.time = self.time_of(&state);
            times.substeps += 1;
            for (total, stage) in times.seconds.iter_mut().zip(seconds) {
                *total += stage;
            }
        }
        Ok(Some(times))
    }
}
