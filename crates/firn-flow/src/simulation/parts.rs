//! A flow stepped in parts (firn-mpi's ranks, [`crate::parts`]): one part's
//! substeps, and the states the parts trade.

use super::{FlowError, FlowSimulation};
use crate::parts::{FlowPart, FlowPartState};
use crate::trails::Trails;

impl FlowSimulation {
    /// [`FlowSimulation::advance_to`], moving only `part`'s particles
    /// ([`FlowSimulation::step_part`]).
    pub fn advance_part_to(&mut self, part: FlowPart, until: f64) -> u32 {
        let mut taken = 0;
        let tolerance = 1e-6 * self.dt();
        while (self.substeps + 1) as f64 / self.steps_per_second() <= until + tolerance {
            self.step_part(part);
            taken += 1;
        }
        taken
    }

    /// The state of `part`'s particles, borrowed, one run of consecutive
    /// particles at a time, in index order.
    pub fn part_rows(&self, part: FlowPart) -> impl Iterator<Item = FlowPartState<'_>> {
        let particles = &self.particles;
        part.ranges(particles.len()).map(move |range| {
            let (trail_points, trail_lengths, trail_generations) = match &self.trails {
                Some(trails) => trails.rows(range.clone()),
                None => (&[][..], &[][..], &[][..]),
            };
            FlowPartState {
                positions: &particles.positions[range.clone()],
                velocities: &particles.velocities[range.clone()],
                ages: &particles.ages[range.clone()],
                lifetimes: &particles.lifetimes[range.clone()],
                generations: &particles.generations[range],
                trail_points,
                trail_lengths,
                trail_generations,
            }
        })
    }

    /// Puts `state`, all of `part`'s particles (its
    /// [`FlowSimulation::part_rows`] one after the other) taken from a copy
    /// of this flow at the same substep, in place of `part`'s particles.
    pub fn set_part_state(
        &mut self,
        part: FlowPart,
        state: &FlowPartState<'_>,
    ) -> Result<(), FlowError> {
        let count = part.count(self.particles.len());
        let trail_capacity = self.trails.as_ref().map_or(0, Trails::capacity);
        let trail_rows = if self.trails.is_some() { count } else { 0 };
        let fits = state.positions.len() == count
            && state.velocities.len() == count
            && state.ages.len() == count
            && state.lifetimes.len() == count
            && state.generations.len() == count
            && state.trail_points.len() == trail_rows * trail_capacity
            && state.trail_lengths.len() == trail_rows
            && state.trail_generations.len() == trail_rows;
        if !fits {
            return Err(FlowError::SnapshotMismatch(format!(
                "a part of {} particles where this flow's part holds {count}",
                state.positions.len()
            )));
        }
        let mut start = 0;
        let particles = &mut self.particles;
        for range in part.ranges(particles.len()) {
            let from = start..start + range.len();
            particles.positions[range.clone()].copy_from_slice(&state.positions[from.clone()]);
            particles.velocities[range.clone()].copy_from_slice(&state.velocities[from.clone()]);
            particles.ages[range.clone()].copy_from_slice(&state.ages[from.clone()]);
            particles.lifetimes[range.clone()].copy_from_slice(&state.lifetimes[from.clone()]);
            particles.generations[range.clone()].copy_from_slice(&state.generations[from.clone()]);
            if let Some(trails) = &mut self.trails {
                trails.set_rows(
                    range.start,
                    &state.trail_points[from.start * trail_capacity..from.end * trail_capacity],
                    &state.trail_lengths[from.clone()],
                    &state.trail_generations[from.clone()],
                );
            }
            start = from.end;
        }
        Ok(())
    }
}
