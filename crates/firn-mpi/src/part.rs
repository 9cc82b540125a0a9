//! One rank's particles in the solver: a [`SnowPart`] is a [`Simulation`]
//! of the rank's own particles with the key of each, its place in the
//! whole run's order. The solver knows nothing of parts: every substep the
//! part hands it the keys and the trade of block sums
//! ([`Simulation::step_part`]). A [`GpuPart`] holds them on the rank's GPU
//! instead ([`firn_gpu::snow::parts`]); [`Slab`] is either.

use firn_core::Scene;
use firn_gpu::GpuSnow;
use firn_mpm::{Simulation, SimulationError, Snapshot, SumTrade};
use firn_run::RunError;

use crate::packing::KeyedParticles;

/// A rank's particles, in the CPU solver or on its GPU.
pub(crate) enum Slab {
    /// In a [`Simulation`].
    Cpu(Box<SnowPart>),
    /// In a [`GpuSnow`].
    Gpu(Box<GpuPart>),
}

impl Slab {
    /// The scene.
    pub(crate) fn scene(&self) -> &Scene {
        match self {
            Slab::Cpu(part) => part.simulation.scene(),
            Slab::Gpu(part) => &part.scene,
        }
    }

    /// Simulated time, s.
    pub(crate) fn time(&self) -> f64 {
        match self {
            Slab::Cpu(part) => part.simulation.time(),
            Slab::Gpu(part) => part.started().time(),
        }
    }

    /// The keys of the own particles, in their order.
    pub(crate) fn keys(&self) -> &[u64] {
        match self {
            Slab::Cpu(part) => &part.keys,
            Slab::Gpu(part) => &part.keys,
        }
    }

    /// The own particles and the run's counters, as a snapshot (read back
    /// from the GPU).
    pub(crate) fn snapshot(&self) -> Result<Snapshot, RunError> {
        match self {
            Slab::Cpu(part) => Ok(part.simulation.snapshot()),
            Slab::Gpu(part) => Ok(part.started().snapshot()?),
        }
    }
}

/// A rank's particles on its GPU, with one key per particle (in the GPU's
/// order, which never changes: one GPU process never reorders its
/// particles).
pub(crate) struct GpuPart {
    /// The run of the particles; `None` only while it starts.
    pub(crate) gpu: Option<GpuSnow>,
    pub(crate) keys: Vec<u64>,
    pub(crate) scene: Scene,
}

impl GpuPart {
    /// The run, once started.
    fn started(&self) -> &GpuSnow {
        self.gpu.as_ref().expect("a started part")
    }
}

/// A simulation of one rank's particles, with one key per particle.
pub(crate) struct SnowPart {
    simulation: Simulation,
    /// The key of each particle of `simulation`, in its order.
    keys: Vec<u64>,
}

impl SnowPart {
    /// The part of `own` particles at simulated time `time` after `steps`
    /// substeps, whose next Δt the whole run's largest |v_p|² and squared
    /// wave speed (`bounds`) make, with the whole run's rigid bodies as
    /// `rigid` saved them (at their start without).
    pub(crate) fn new(
        scene: Scene,
        (time, steps): (f64, u64),
        bounds: [f32; 2],
        rigid: Option<&[u8]>,
        own: KeyedParticles,
    ) -> SnowPart {
        // Rank 0 made these bytes from its own solver's bodies, of this
        // scene, with this program: they read back.
        let simulation = Simulation::empty(scene, time, steps, rigid)
            .expect("rank 0's saved rigid bodies read back");
        let mut part = SnowPart {
            simulation,
            keys: Vec::new(),
        };
        part.set_motion_bounds(bounds);
        part.set(own);
        part
    }

    /// The simulation of the own particles.
    pub(crate) fn simulation(&self) -> &Simulation {
        &self.simulation
    }

    /// Takes the own particles and their keys out (leaving none), e.g. to
    /// send some of them to another rank; [`SnowPart::set`] puts particles
    /// back.
    pub(crate) fn take(&mut self) -> KeyedParticles {
        KeyedParticles {
            particles: self.simulation.take_particles(),
            keys: std::mem::take(&mut self.keys),
        }
    }

    /// Gives the part its particles for the substeps to come, those of its
    /// slab, in any order: the keys order them.
    pub(crate) fn set(&mut self, own: KeyedParticles) {
        assert_eq!(own.keys.len(), own.particles.len(), "one key per particle");
        self.simulation.set_particles(own.particles);
        self.keys = own.keys;
    }

    /// One substep of the own particles, never past `until`, trading block
    /// sums through `trade`; returns its Δt. Every part must take it, with
    /// the same Δt: the caller reduces [`Simulation::motion_bounds`] over
    /// the parts and sets the result ([`SnowPart::set_motion_bounds`]).
    pub(crate) fn step(
        &mut self,
        until: f64,
        trade: &mut dyn SumTrade,
    ) -> Result<f32, SimulationError> {
        self.simulation.step_part(until, &self.keys, trade)
    }

    /// Sets what the next Δt is made of: the largest |v_p|² and squared
    /// wave speed over all parts.
    pub(crate) fn set_motion_bounds(&mut self, bounds: [f32; 2]) {
        self.simulation.set_motion_bounds(bounds[0], bounds[1]);
    }
}
