//! A scene running live in the viewer, on the CPU or on the viewer's own
//! GPU device. On the GPU the particles are drawn straight from the
//! simulation's buffers; nothing is copied back to the host.

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{ColorBy, FlowSettings, Material, SceneKind};
use firn_flow::FlowSimulation;
use firn_gpu::{GpuContext, GpuFlow, GpuSnow};
use firn_mpm::Simulation;
use glam::Vec3;

use crate::draw::ParticleSource;

/// A running simulation of either kind on either backend.
pub enum LiveSimulation {
    /// Snow on the CPU MPM solver.
    CpuSnow(Box<Simulation>),
    /// A curl-noise flow on the CPU.
    CpuFlow(Box<FlowSimulation>),
    /// Snow on the GPU.
    GpuSnow(Box<GpuSnow>),
    /// A curl-noise flow on the GPU.
    GpuFlow(Box<GpuFlow>),
}

/// A frame's particles on the host (for simulations on the CPU): the
/// simulation's own positions, and the values and trails made for drawing.
pub struct HostParticles<'a> {
    /// Positions.
    pub positions: &'a [Vec3],
    /// Values of the colour quantity, if it is a ramp quantity.
    pub values: Option<Vec<f32>>,
    /// Trail rings oldest first, their capacity, and their lengths.
    pub trails: Option<(Vec<Vec3>, usize, Vec<u32>)>,
}

impl HostParticles<'_> {
    /// The renderer's view of these particles.
    pub fn source(&self) -> ParticleSource<'_> {
        ParticleSource::Host {
            positions: self.positions,
            values: self.values.as_deref(),
            trails: self.trails.as_ref().map(|(points, capacity, lengths)| {
                firn_render::trails::Trails {
                    points,
                    capacity: *capacity,
                    lengths,
                }
            }),
        }
    }
}

impl LiveSimulation {
    /// Starts `scene` at time 0, on `gpu` when given, else on the CPU.
    pub fn start(scene: Scene, gpu: Option<&Arc<GpuContext>>) -> Result<LiveSimulation, String> {
        let text = |error: &dyn std::fmt::Display| error.to_string();
        Ok(match (&scene.kind, gpu) {
            (SceneKind::Snow, None) => {
                LiveSimulation::CpuSnow(Box::new(Simulation::new(scene).map_err(|e| text(&e))?))
            }
            (SceneKind::Flow(_), None) => {
                LiveSimulation::CpuFlow(Box::new(FlowSimulation::new(scene).map_err(|e| text(&e))?))
            }
            (SceneKind::Snow, Some(context)) => LiveSimulation::GpuSnow(Box::new(
                GpuSnow::new(Arc::clone(context), scene).map_err(|e| text(&e))?,
            )),
            (SceneKind::Flow(_), Some(context)) => LiveSimulation::GpuFlow(Box::new(
                GpuFlow::new(Arc::clone(context), scene).map_err(|e| text(&e))?,
            )),
        })
    }

    /// Whether the simulation runs on the GPU.
    pub fn on_gpu(&self) -> bool {
        matches!(
            self,
            LiveSimulation::GpuSnow(_) | LiveSimulation::GpuFlow(_)
        )
    }

    /// The scene as it runs now (with any parameters changed live).
    pub fn scene(&self) -> &Scene {
        match self {
            LiveSimulation::CpuSnow(simulation) => simulation.scene(),
            LiveSimulation::CpuFlow(flow) => flow.scene(),
            LiveSimulation::GpuSnow(snow) => snow.scene(),
            LiveSimulation::GpuFlow(flow) => flow.scene(),
        }
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        match self {
            LiveSimulation::CpuSnow(simulation) => simulation.time(),
            LiveSimulation::CpuFlow(flow) => flow.time(),
            LiveSimulation::GpuSnow(snow) => snow.time(),
            LiveSimulation::GpuFlow(flow) => flow.time(),
        }
    }

    /// Live particles.
    pub fn particle_count(&self) -> usize {
        match self {
            LiveSimulation::CpuSnow(simulation) => simulation.particles().len(),
            LiveSimulation::CpuFlow(flow) => flow.len(),
            LiveSimulation::GpuSnow(snow) => snow.particle_arrays().count as usize,
            LiveSimulation::GpuFlow(flow) => flow.len(),
        }
    }

    /// Advances to simulated time `until`; returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, String> {
        match self {
            LiveSimulation::CpuSnow(simulation) => {
                simulation.advance_to(until).map_err(|e| e.to_string())
            }
            LiveSimulation::CpuFlow(flow) => Ok(flow.advance_to(until)),
            LiveSimulation::GpuSnow(snow) => snow.advance_to(until).map_err(|e| e.to_string()),
            LiveSimulation::GpuFlow(flow) => flow.advance_to(until).map_err(|e| e.to_string()),
        }
    }

    /// Replaces the snow materials; they take effect at the next substep.
    pub fn set_materials(&mut self, materials: &[Material]) -> Result<(), String> {
        match self {
            LiveSimulation::CpuSnow(simulation) => simulation
                .set_materials(materials)
                .map_err(|e| e.to_string()),
            LiveSimulation::GpuSnow(snow) => {
                snow.set_materials(materials).map_err(|e| e.to_string())
            }
            LiveSimulation::CpuFlow(_) | LiveSimulation::GpuFlow(_) => {
                Err("a flow scene has no snow materials".into())
            }
        }
    }

    /// Replaces the flow's field parameters; they take effect at the next
    /// substep.
    pub fn set_flow(&mut self, settings: &FlowSettings) -> Result<(), String> {
        match self {
            LiveSimulation::CpuFlow(flow) => flow
                .set_settings(settings.clone())
                .map_err(|e| e.to_string()),
            LiveSimulation::GpuFlow(flow) => flow
                .set_settings(settings.clone())
                .map_err(|e| e.to_string()),
            LiveSimulation::CpuSnow(_) | LiveSimulation::GpuSnow(_) => {
                Err("a snow scene has no flow parameters".into())
            }
        }
    }

    /// The particles of a CPU simulation, with the values of `color_by`
    /// (`None` on the GPU: see [`LiveSimulation::device_source`]).
    pub fn host_particles(&self, color_by: ColorBy) -> Option<HostParticles<'_>> {
        match self {
            LiveSimulation::CpuSnow(simulation) => Some(HostParticles {
                positions: &simulation.particles().position,
                values: simulation.color_values(color_by),
                trails: None,
            }),
            LiveSimulation::CpuFlow(flow) => Some(HostParticles {
                positions: flow.positions(),
                values: (color_by == ColorBy::Speed)
                    .then(|| flow.velocities().iter().map(|v| v.length()).collect()),
                trails: flow.trails().map(|trails| {
                    let (points, lengths) = trails.oldest_first();
                    (points, trails.capacity(), lengths)
                }),
            }),
            LiveSimulation::GpuSnow(_) | LiveSimulation::GpuFlow(_) => None,
        }
    }

    /// The particles of a GPU simulation, in its own buffers (`None` on the CPU).
    pub fn device_source(&self) -> Option<ParticleSource<'_>> {
        match self {
            LiveSimulation::GpuSnow(snow) => Some(ParticleSource::Device(snow.particle_arrays())),
            LiveSimulation::GpuFlow(flow) => Some(ParticleSource::Device(flow.particle_arrays())),
            LiveSimulation::CpuSnow(_) | LiveSimulation::CpuFlow(_) => None,
        }
    }
}
