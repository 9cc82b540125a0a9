//! A frame's caches: the scene's `[output] attributes` in each of its
//! `[output] formats` (binary PLY, VTK PolyData), the ParaView collection
//! (PVD) that lists the VTK frames by time, a snow frame's OpenVDB
//! volumes (`vdb`, see [`crate::volumes`]), a snow frame's surface mesh
//! (`mesh`, PLY and OBJ, see [`crate::surface`]) and the run's USD stage
//! (`usd`, see [`crate::usd_stage`]). A snow scene with spindrift writes its drift
//! particles beside the snow, in `drift/` (PLY and VTK), as a `drift` grid
//! in the snow's OpenVDB file and as a `Drift` prim in the USD stage.

use firn_core::scene::{Attribute as SceneAttribute, CacheFormat, Scene};
use firn_io::{
    Attribute, FloatGrid, FrameData, IoError, MeshData, PvdCollection, write_mesh_obj,
    write_mesh_ply, write_ply, write_usd_frame, write_vdb, write_vtp,
};
use firn_mesh::TriangleMesh;
use firn_mpm::{Particles, Simulation};
use glam::Vec3;

use crate::run_dir::RunDirectory;
use crate::simulation::HostState;
use crate::surface::scene_surface;
use crate::usd_stage::{collider_positions, usd_stage};
use crate::volumes::{density_grid, snow_volumes};

/// A frame's caches once written.
pub struct WrittenFrame {
    /// The files' paths relative to the run directory.
    pub files: Vec<String>,
    /// The snow's surface, where the `mesh` format made it.
    pub surface: Option<TriangleMesh>,
}

/// Writes frame `index` of `state` in every cache format of its scene into
/// `run`, and updates the collection `pvd` with a VTK frame.
pub fn write_frame(
    state: HostState<'_>,
    index: u32,
    run: &RunDirectory,
    pvd: &mut PvdCollection,
) -> Result<WrittenFrame, IoError> {
    match state {
        HostState::Snow(simulation) => write_snow_frame(simulation, index, run, pvd),
        HostState::Flow(flow) => {
            let frame = FrameData::new(index, flow.time(), flow.positions())
                .with_attribute(Attribute::vector("velocity", flow.velocities()))
                .with_attribute(Attribute::scalar("age", flow.ages()));
            let files = write_caches(flow.scene(), &frame, None, &Volumes::default(), run, pvd)?;
            Ok(WrittenFrame {
                files,
                surface: None,
            })
        }
    }
}

/// Attribute arrays computed for output (those the solver does not store).
struct DerivedAttributes {
    density: Vec<f32>,
    elastic_j: Vec<f32>,
    material: Vec<u32>,
}

/// Writes a snow frame with the scene's `[output] attributes`.
fn write_snow_frame(
    simulation: &Simulation,
    index: u32,
    run: &RunDirectory,
    pvd: &mut PvdCollection,
) -> Result<WrittenFrame, IoError> {
    let scene = simulation.scene();
    let particles = simulation.particles();
    let wanted = &scene.output.attributes;
    let derived = DerivedAttributes {
        density: if wanted.contains(&SceneAttribute::Density) {
            simulation.densities()
        } else {
            Vec::new()
        },
        elastic_j: if wanted.contains(&SceneAttribute::ElasticJ) {
            simulation.elastic_j()
        } else {
            Vec::new()
        },
        material: particles.material.iter().map(|&m| m as u32).collect(),
    };
    let mut frame = FrameData::new(index, simulation.time(), &particles.position);
    for attribute in wanted {
        frame = frame.with_attribute(attribute_data(*attribute, particles, &derived));
    }
    let drift = scene.spindrift().map(|_| {
        let drift = simulation.drift();
        FrameData::new(index, simulation.time(), &drift.position)
            .with_attribute(Attribute::vector("velocity", &drift.velocity))
            .with_attribute(Attribute::scalar("mass", &drift.mass))
    });
    let formats = &scene.output.formats;
    let mut grids = Vec::new();
    if formats.contains(&CacheFormat::Vdb) {
        grids = scene_volumes(scene, particles);
        if scene.spindrift().is_some() {
            let drift = simulation.drift();
            grids.push(drift_volume(scene, &drift.position, &drift.mass));
        }
    }
    let volumes = Volumes {
        grids,
        surface: formats
            .contains(&CacheFormat::Mesh)
            .then(|| scene_surface(scene, &particles.position, &particles.mass)),
    };
    let mut files = write_caches(scene, &frame, drift.as_ref(), &volumes, run, pvd)?;
    if let Some(drift) = &drift {
        files.extend(write_drift_frame(scene, drift, run)?);
    }
    Ok(WrittenFrame {
        files,
        surface: volumes.surface,
    })
}

/// Writes a snow frame's drift (`[wind.spindrift]`, each particle with its
/// velocity and mass) beside its snow, in `drift/` as PLY and VTK PolyData
/// for the scene's `ply` and `vtk` formats; returns the files' paths
/// relative to the run directory. (The `vdb` and `usd` caches hold the
/// drift in the snow's files: a `drift` grid, a `Drift` points prim.)
fn write_drift_frame(
    scene: &Scene,
    drift: &FrameData,
    run: &RunDirectory,
) -> Result<Vec<String>, IoError> {
    let mut files = Vec::new();
    for &format in &scene.output.formats {
        let name = match format {
            CacheFormat::Ply | CacheFormat::Vtk => {
                RunDirectory::drift_cache_name(format, drift.index)
            }
            CacheFormat::Vdb | CacheFormat::Usd | CacheFormat::Mesh => continue,
        };
        let path = run.path().join(&name);
        firn_io::ensure_writable_dir(path.parent().unwrap_or(run.path()))?;
        match format {
            CacheFormat::Ply => write_ply(&path, drift)?,
            _ => write_vtp(&path, drift)?,
        }
        files.push(name);
    }
    Ok(files)
}

/// What a snow frame's particles are turned into: the OpenVDB grids
/// (`vdb`) and the surface mesh (`mesh`), each made only when written.
#[derive(Default)]
struct Volumes {
    grids: Vec<FloatGrid>,
    surface: Option<TriangleMesh>,
}

/// The `drift` grid of a spindrift scene's frame: the drift's mass per
/// volume (kg/m³) on the snow's voxels, a fog volume beside the snow's
/// `density`.
fn drift_volume(scene: &Scene, positions: &[Vec3], masses: &[f32]) -> FloatGrid {
    let voxel = scene.output.vdb.voxel_size_for(scene.domain.cell_size);
    let mut grid = density_grid(positions, masses, scene.domain.min, voxel);
    grid.name = "drift".to_string();
    grid
}

/// The OpenVDB grids of a snow frame, as the scene's `[output.vdb]` asks.
fn scene_volumes(scene: &Scene, particles: &Particles) -> Vec<FloatGrid> {
    let settings = &scene.output.vdb;
    let rest_density = scene
        .materials
        .iter()
        .map(|material| material.density)
        .fold(0.0, f32::max);
    snow_volumes(
        &particles.position,
        &particles.mass,
        scene.domain.min,
        settings.voxel_size_for(scene.domain.cell_size),
        settings.level_set.then_some(rest_density),
    )
}

/// Writes `frame` in each of `scene`'s formats into `run` (`volumes` for
/// `vdb` and `mesh`, and a spindrift scene's `drift` for `usd`); returns
/// the files' paths relative to the run directory.
fn write_caches(
    scene: &Scene,
    frame: &FrameData,
    drift: Option<&FrameData>,
    volumes: &Volumes,
    run: &RunDirectory,
    pvd: &mut PvdCollection,
) -> Result<Vec<String>, IoError> {
    let mut files = Vec::new();
    for &format in &scene.output.formats {
        let name = RunDirectory::cache_name(format, frame.index);
        let path = run.path().join(&name);
        match format {
            CacheFormat::Ply => write_ply(&path, frame)?,
            CacheFormat::Vtk => {
                write_vtp(&path, frame)?;
                pvd.remove_after(frame.time - 1e-12);
                pvd.push(frame.time, name.clone());
                pvd.write(&run.collection_path())?;
            }
            CacheFormat::Vdb => write_vdb(&path, &volumes.grids)?,
            CacheFormat::Mesh => {
                let surface = volumes.surface.as_ref().map_or(
                    MeshData {
                        vertices: &[],
                        triangles: &[],
                    },
                    |mesh| MeshData {
                        vertices: &mesh.vertices,
                        triangles: &mesh.triangles,
                    },
                );
                write_mesh_ply(&path, surface)?;
                let obj = RunDirectory::mesh_obj_name(frame.index);
                write_mesh_obj(&run.path().join(&obj), surface)?;
                files.extend([name, obj]);
                continue;
            }
            CacheFormat::Usd => write_usd_frame(
                run.path(),
                &usd_stage(scene, frame.index),
                &[Some(frame), drift]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>(),
                &collider_positions(scene, frame.time),
            )?,
        }
        files.push(name);
    }
    Ok(files)
}

/// The values of one cached attribute.
fn attribute_data<'a>(
    attribute: SceneAttribute,
    particles: &'a Particles,
    derived: &'a DerivedAttributes,
) -> Attribute<'a> {
    match attribute {
        SceneAttribute::Velocity => Attribute::vector("velocity", &particles.velocity),
        SceneAttribute::PlasticJ => Attribute::scalar("plastic_j", &particles.plastic_j),
        SceneAttribute::ElasticJ => Attribute::scalar("elastic_j", &derived.elastic_j),
        SceneAttribute::Density => Attribute::scalar("density", &derived.density),
        SceneAttribute::Mass => Attribute::scalar("mass", &particles.mass),
        SceneAttribute::Material => Attribute::integer("material", &derived.material),
    }
}
