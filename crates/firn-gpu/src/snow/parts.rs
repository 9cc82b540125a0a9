//! One part of a snow run split between processes, each with its own GPU
//! (MPI ranks, `firn-mpi`): a [`GpuSnow`] of the part's particles that
//! steps one substep at a time ([`GpuSnow::part_substep`]) and, between its
//! scatter and its grid update, trades grid sums with the other parts
//! (`shaders/snow/parts.wgsl`).
//!
//! The GPU's sums are 64-bit fixed-point integers and every other stage
//! works per particle or per node, so a run's bits do not depend on which
//! part holds a particle: each part scatters its own particles, then adds
//! the other parts' sums of every grid block it reaches (its sparse grid's
//! blocks, in block order) that they reach too. Every node a part reads
//! then holds the one process's sums, and the grid update and the gather
//! give the one process's bits. Which blocks two parts share is found each
//! substep: every part tells all others the first and last block it
//! reaches, and the parts whose ranges overlap swap their block lists.
//!
//! The parts must also take the same Δt: the caller reduces
//! [`GpuSnow::motion_bounds`] over the parts after each substep and hands
//! the result back ([`GpuSnow::set_motion_bounds`]), as it agrees on
//! failures.

use firn_core::Scene;
use firn_mpm::Snapshot;

use super::layout::StepState;
use super::program::{Kernel, StepProgram, compute_pass};
use super::spindrift::joined;
use super::{GpuSnow, is_implicit};
use crate::buffers::read_back;
use crate::context::GpuContext;
use crate::dispatch::workgroups;
use crate::error::GpuError;

/// Blocks whose sums one pack or add moves at most; more go in turns.
pub const TRADE_CHUNK_BLOCKS: u32 = 2048;

/// How the parts of a split run talk (MPI, or threads in the tests). Every
/// part must call each method alike, in the same order.
pub trait PartTrade {
    /// This part's number, `0..parts()`.
    fn part(&self) -> usize;

    /// The number of parts.
    fn parts(&self) -> usize;

    /// Every part's `words`, by part.
    fn all_gather(&mut self, words: &[u32]) -> Vec<Vec<u32>>;

    /// Sends `outgoing[p]` to each of `partners` (a relation every part
    /// sees alike, and symmetric) and returns what each sent this one, by
    /// part (empty from the others).
    fn exchange_with(&mut self, outgoing: Vec<Vec<u32>>, partners: &[usize]) -> Vec<Vec<u32>>;
}

/// What one substep of a part did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PartSubstep {
    /// The frame had ended: nothing ran (on every part alike).
    FrameDone,
    /// A substep of length `dt` ran.
    Taken {
        /// Its Δt, s.
        dt: f32,
    },
}

/// The pack and add kernels of `parts.wgsl`.
pub struct PartKernels {
    pack: Kernel,
    add: Kernel,
}

impl PartKernels {
    /// The kernels of `program`.
    pub fn new(program: &StepProgram) -> PartKernels {
        PartKernels {
            pack: program.kernel("pack_traded_sums"),
            add: program.kernel("add_traded_sums"),
        }
    }
}

/// The blocks this part shares with each partner: per partner, the slots
/// (in this part's grid) of the blocks both reach, in block order.
struct SharedBlocks {
    partners: Vec<usize>,
    slots: Vec<Vec<u32>>,
}

impl GpuSnow {
    /// Starts a frame that ends at simulated time `until`, to be stepped by
    /// [`GpuSnow::part_substep`] until it says the frame is done.
    pub fn begin_part_frame(&mut self, until: f64) {
        self.begin_frame(until);
    }

    /// One substep of this part, trading sums with the other parts through
    /// `trade`; every part must call it alike. A failure here (a particle
    /// in trouble, a grid that cannot grow) is this part's: the caller
    /// agrees with the others on it before the next substep.
    pub fn part_substep(&mut self, trade: &mut dyn PartTrade) -> Result<PartSubstep, GpuError> {
        self.check_step_length(&self.last)?;
        let scattered = self.scatter_part();
        if let Ok(None) = scattered {
            // As a whole frame's batches end (`GpuSnow::advance_to`).
            self.time = self.frame_end;
            return Ok(PartSubstep::FrameDone);
        }
        let blocks = match &scattered {
            Ok(Some(state)) => self.reached_blocks(state.grid_blocks),
            Ok(None) | Err(_) => Ok(Vec::new()),
        };
        let own = blocks.as_ref().map(Vec::clone).unwrap_or_default();
        let traded = self.trade_sums(&own, trade);
        scattered?;
        blocks?;
        traded?;
        let state = self
            .substep
            .finish_part_substep(&self.context, &self.buffers)?;
        self.last = state;
        self.steps += 1;
        self.time = self.time_of(&state);
        self.check_trouble(&state)?;
        Ok(PartSubstep::Taken { dt: state.dt })
    }

    /// Replaces this part's particles with those of `snapshot` (of the
    /// same time), between frames: in place where the buffers have room,
    /// else in a part built anew.
    pub fn replace_particles(&mut self, snapshot: &Snapshot) -> Result<(), GpuError> {
        let (particles, material_words) = joined(&snapshot.particles, &snapshot.drift);
        if particles.len() as u64 > self.memory.particles {
            let (context, scene) = (self.context.clone(), self.scene.clone());
            *self = GpuSnow::part_from_snapshot(context, scene, snapshot)?;
            return Ok(());
        }
        self.buffers
            .particles
            .write(&self.context, &particles, &material_words);
        self.particle_count = particles.len();
        self.params.dims[3] = particles.len() as u32;
        self.substep
            .set_particle_count(&self.context, particles.len() as u32);
        Ok(())
    }

    /// The largest |v_p|² and squared elastic wave speed of this part's
    /// particles after the last substep.
    pub fn motion_bounds(&self) -> (f32, f32) {
        (
            f32::from_bits(self.last.max_speed_bits),
            f32::from_bits(self.last.max_wave_bits),
        )
    }

    /// Sets what the next Δt is made of: the largest |v_p|² and squared
    /// wave speed over all parts.
    pub fn set_motion_bounds(&mut self, speed_squared: f32, wave_speed_squared: f32) {
        self.last.max_speed_bits = speed_squared.to_bits();
        self.last.max_wave_bits = wave_speed_squared.to_bits();
        self.substep
            .write_motion_bounds(&self.context, speed_squared, wave_speed_squared);
    }

    /// `Ok` when `scene` runs split between GPUs (MPI ranks); otherwise
    /// what it lacks.
    pub fn check_splittable(scene: &Scene) -> Result<(), GpuError> {
        GpuSnow::check_supported(scene)?;
        let lacking = if is_implicit(scene) {
            Some("the semi-implicit integrator, whose solve spans the whole grid")
        } else if scene.wind.is_some() {
            Some("wind, whose drag reads the masses of nodes around each node")
        } else if !scene.rigid_bodies.is_empty() {
            Some("rigid bodies")
        } else {
            None
        };
        match lacking {
            None => Ok(()),
            Some(what) => Err(GpuError::Unsupported {
                what: format!("the GPU backend on MPI ranks does not run {what} yet"),
                fix: "run with --backend cpu under mpirun, or on one GPU without mpirun".into(),
            }),
        }
    }

    /// The blocks, the clearing and the scatter of the next substep;
    /// `None` when the frame had ended. Grows the grid or uploads mesh
    /// frames when the substep waits for them, and tries again.
    fn scatter_part(&mut self) -> Result<Option<StepState>, GpuError> {
        loop {
            let state = self
                .substep
                .run_part_scatter(&self.context, &self.buffers)?;
            if state.waiting != 0 {
                self.last = state;
                self.serve_wait(&state)?;
                continue;
            }
            return Ok((state.running != 0).then_some(state));
        }
    }

    /// The blocks the grid holds this substep (`blocks` of them), by slot:
    /// sorted block indices.
    fn reached_blocks(&self, blocks: u32) -> Result<Vec<u32>, GpuError> {
        let bins = &self.buffers.binning.bins;
        let words = read_back::<u32>(&self.context, &[(bins, 3 * blocks as usize)])?.remove(0);
        Ok(words.chunks_exact(3).map(|slot| slot[2]).collect())
    }

    /// Trades the sums of the blocks in `own` (this part's, by slot) that
    /// other parts reach too, and adds theirs into the grid.
    fn trade_sums(&self, own: &[u32], trade: &mut dyn PartTrade) -> Result<(), GpuError> {
        let shared = shared_blocks(own, trade);
        let mut packed = Vec::new();
        let mut outgoing = vec![Vec::new(); trade.parts()];
        let block_words = self.substep.traded_block_words() as usize;
        let packing: Result<(), GpuError> = (|| {
            let mut all: Vec<u32> = shared.slots.iter().flatten().copied().collect();
            all.sort_unstable();
            all.dedup();
            packed = self.pack(&all)?;
            for (&partner, slots) in shared.partners.iter().zip(&shared.slots) {
                for slot in slots {
                    let place = all.binary_search(slot).expect("a packed slot");
                    let words = &packed[place * block_words..(place + 1) * block_words];
                    outgoing[partner].extend_from_slice(words);
                }
            }
            Ok(())
        })();
        let incoming = trade.exchange_with(outgoing, &shared.partners);
        packing?;
        for (&partner, slots) in shared.partners.iter().zip(&shared.slots) {
            self.add(slots, &incoming[partner])?;
        }
        Ok(())
    }

    /// The sums of the blocks in `slots`, `traded_block_words` each, in
    /// their order.
    fn pack(&self, slots: &[u32]) -> Result<Vec<u32>, GpuError> {
        let mut words = Vec::new();
        for chunk in slots.chunks(self.buffers.trade.capacity as usize) {
            self.substep
                .run_traded(&self.context, &self.buffers, chunk, None)?;
            let size = chunk.len() * self.substep.traded_block_words() as usize;
            words.extend(
                read_back::<u32>(&self.context, &[(&self.buffers.trade.words, size)])?.remove(0),
            );
        }
        Ok(words)
    }

    /// Adds `words`, another part's sums of the blocks in `slots`, into
    /// the grid.
    fn add(&self, slots: &[u32], words: &[u32]) -> Result<(), GpuError> {
        let block_words = self.substep.traded_block_words() as usize;
        let capacity = self.buffers.trade.capacity as usize;
        for (chunk, chunk_words) in slots
            .chunks(capacity)
            .zip(words.chunks(capacity * block_words))
        {
            self.substep
                .run_traded(&self.context, &self.buffers, chunk, Some(chunk_words))?;
        }
        Ok(())
    }
}

/// Which blocks of `own` (sorted block indices, by slot) each other part
/// reaches too. Collective: every part tells all the first and last block
/// it reaches; the parts whose ranges overlap swap their lists.
fn shared_blocks(own: &[u32], trade: &mut dyn PartTrade) -> SharedBlocks {
    let range = match (own.first(), own.last()) {
        (Some(&first), Some(&last)) => [first, last],
        _ => [u32::MAX, 0],
    };
    let me = trade.part();
    let ranges = trade.all_gather(&range);
    let partners: Vec<usize> = ranges
        .iter()
        .enumerate()
        .filter(|&(part, theirs)| part != me && theirs[0] <= range[1] && range[0] <= theirs[1])
        .map(|(part, _)| part)
        .collect();
    let mut outgoing = vec![Vec::new(); trade.parts()];
    for &partner in &partners {
        outgoing[partner] = own.to_vec();
    }
    let lists = trade.exchange_with(outgoing, &partners);
    let slots = partners
        .iter()
        .map(|&partner| common_slots(own, &lists[partner]))
        .collect();
    SharedBlocks { partners, slots }
}

/// The slots in `own` (sorted block indices) of the blocks also in
/// `theirs` (sorted).
fn common_slots(own: &[u32], theirs: &[u32]) -> Vec<u32> {
    let mut slots = Vec::new();
    let (mut i, mut j) = (0, 0);
    while i < own.len() && j < theirs.len() {
        match own[i].cmp(&theirs[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                slots.push(i as u32);
                i += 1;
                j += 1;
            }
        }
    }
    slots
}

impl PartKernels {
    /// Records the pack (`add` false) or the add of `blocks` listed blocks.
    pub fn record(
        &self,
        context: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        blocks: u32,
        add: bool,
    ) {
        let limit = context.limits.max_compute_workgroups_per_dimension;
        let (x, y, _) = workgroups(blocks * 64, limit);
        let kernel = if add { &self.add } else { &self.pack };
        kernel.dispatch(&mut compute_pass(encoder, "traded sums"), (x, y, 1));
    }
}

#[cfg(test)]
mod tests {
    use super::common_slots;

    #[test]
    fn common_slots_are_the_places_in_own_of_the_shared_blocks() {
        assert_eq!(common_slots(&[2, 5, 9, 12], &[1, 5, 12, 30]), vec![1, 3]);
        assert_eq!(common_slots(&[2, 5], &[]), Vec::<u32>::new());
        assert_eq!(common_slots(&[], &[3]), Vec::<u32>::new());
    }
}
