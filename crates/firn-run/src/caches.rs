//! A frame's caches: the scene's `[output] attributes` in each of its
//! `[output] formats` (binary PLY, VTK PolyData), the ParaView collection
//! (PVD) that lists the VTK frames by time, a snow frame's OpenVDB
//! volumes (`vdb`, see [`crate::volumes`]), a snow frame's surface mesh
//! (`mesh`, PLY and OBJ, see [`crate::surface`], and its rigid bodies in
//! one OBJ beside it, see [`crate::body_meshes`]) and the run's USD stage
//! (`usd`, see [`crate::usd_stage`]). A snow scene with spindrift writes its drift
//! particles beside the snow, in `drift/` (PLY and VTK), as a `drift` grid
//! in the snow's OpenVDB file and as a `Drift` prim in the USD stage.

use std::path::Path;

use firn_core::scene::{Attribute as SceneAttribute, CacheFormat, Scene, WorkEstimate};
use firn_io::atomic::WRITE_BUFFER_BYTES;
use firn_io::{
    Attribute, BodyPose, CHUNK_VALUES, FloatGrid, FrameData, IoError, MeshData, PvdCollection,
    UsdSolids, write_mesh_obj, write_mesh_ply, write_ply, write_usd_frame, write_vdb, write_vtp,
};
use firn_mesh::TriangleMesh;
use firn_mpm::{Particles, SnowView};
use glam::Vec3;

use crate::body_meshes::bodies_mesh;
use crate::run_dir::RunDirectory;
use crate::simulation::{HostState, body_poses};
use crate::surface::scene_surface;
use crate::usd_stage::{usd_body_samples, usd_collider_samples, usd_stage};
use crate::volumes::{density_grid, snow_volumes};

/// Bytes a `vdb` cache holds per voxel of snow while a frame is written:
/// the `density` grid's leaves (4 bytes a voxel and its mask, with the
/// leaves at the snow's edge partly empty: about 12) and its file, encoded
/// whole before it is written (as much again).
const VDB_BYTES_PER_VOXEL: u64 = 24;

/// What the `surface` level set adds per voxel of snow: its distances on
/// the narrow band, its grid and its share of the file.
const LEVEL_SET_BYTES_PER_VOXEL: u64 = 36;

/// Bytes a `mesh` cache holds per voxel of snow: the density grid and its
/// blurred copy (about 12 each), the surface and its PLY and OBJ files,
/// each encoded whole before it is written (a snowball of 268,000
/// particles, a voxel per cell, took about 80 in all).
const MESH_BYTES_PER_VOXEL: u64 = 80;

/// Bytes the cache writers hold beyond the solver's own arrays while they
/// write a frame of `scene` (whose bodies `work` estimates): the file's
/// write buffer and a chunk of particles' values (the particles stream
/// from the solver's arrays, a chunk at a time, and so does a checkpoint),
/// and for `vdb` and `mesh` the volumes made of the frame, which follow the
/// snow's volume.
pub fn writer_bytes(scene: &Scene, work: &WorkEstimate) -> u64 {
    // A particle's record: its position and the attributes, or (a flow's
    // frame, a snow frame's drift) its position, velocity and one scalar.
    let columns: u64 = 3 + scene
        .output
        .attributes
        .iter()
        .map(|attribute| match attribute {
            SceneAttribute::Velocity => 3,
            _ => 1,
        })
        .sum::<u64>();
    let chunk = CHUNK_VALUES as u64 * size_of::<f32>() as u64 * columns.max(7);
    let formats = &scene.output.formats;
    let cell = f64::from(scene.domain.cell_size);
    let mut volumes = 0;
    if formats.contains(&CacheFormat::Vdb) {
        let settings = &scene.output.vdb;
        let per_voxel = VDB_BYTES_PER_VOXEL
            + if settings.level_set {
                LEVEL_SET_BYTES_PER_VOXEL
            } else {
                0
            };
        let voxel = settings.voxel_size_for(scene.domain.cell_size);
        let voxels = snow_voxels(scene, work, cell / f64::from(voxel));
        volumes += voxels.saturating_mul(per_voxel);
    }
    if formats.contains(&CacheFormat::Mesh) {
        let voxel = scene.output.mesh.voxel_size_for(scene.domain.cell_size);
        let voxels = snow_voxels(scene, work, cell / f64::from(voxel));
        volumes += voxels.saturating_mul(MESH_BYTES_PER_VOXEL);
    }
    (WRITE_BUFFER_BYTES as u64 + chunk).saturating_add(volumes)
}

/// Voxels the bodies of `scene` fill: their cells, each of
/// `voxels_per_cell_edge`³ voxels (none for a flow).
fn snow_voxels(scene: &Scene, work: &WorkEstimate, voxels_per_cell_edge: f64) -> u64 {
    let cells: f64 = scene
        .bodies
        .iter()
        .zip(&work.bodies)
        .map(|(body, estimate)| {
            estimate.particles as f64 / f64::from(body.particles_per_cell.max(1))
        })
        .sum();
    let voxels = cells * voxels_per_cell_edge.powi(3);
    if voxels.is_finite() {
        voxels.min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    }
}

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
    write_frame_with_pieces(state, index, run, pvd, None)
}

/// [`write_frame`], where `vtk_pieces`, when given, are the frame's VTK
/// files already written in pieces (part, path; a run split between MPI
/// ranks): they are listed in `pvd` in place of one file.
pub fn write_frame_with_pieces(
    state: HostState<'_>,
    index: u32,
    run: &RunDirectory,
    pvd: &mut PvdCollection,
    vtk_pieces: Option<Vec<(u32, String)>>,
) -> Result<WrittenFrame, IoError> {
    let mut collection = Collection { pvd, vtk_pieces };
    match state {
        HostState::Snow(snow) => write_snow_frame(snow, index, run, &mut collection),
        HostState::Flow(flow) => {
            let frame = FrameData::new(index, flow.time(), flow.positions())
                .with_attribute(Attribute::vector("velocity", flow.velocities()))
                .with_attribute(Attribute::scalar("age", flow.ages()));
            let written = FrameContents {
                frame: &frame,
                drift: None,
                bodies: &[],
            };
            let files = write_caches(
                flow.scene(),
                written,
                &Volumes::default(),
                run,
                &mut collection,
            )?;
            Ok(WrittenFrame {
                files,
                surface: None,
            })
        }
    }
}

/// The run's VTK collection, and the frame's VTK pieces where others wrote
/// them.
struct Collection<'a> {
    pvd: &'a mut PvdCollection,
    vtk_pieces: Option<Vec<(u32, String)>>,
}

impl Collection<'_> {
    /// Writes `frame` as VTK at `name`, or takes the pieces written, and
    /// lists the frame in the collection; returns the frame's files.
    fn write_vtk(
        &mut self,
        frame: &FrameData,
        name: String,
        run: &RunDirectory,
    ) -> Result<Vec<String>, IoError> {
        let pieces = match self.vtk_pieces.take() {
            Some(pieces) => pieces,
            None => {
                write_vtp(&run.path().join(&name), frame)?;
                vec![(0, name.clone())]
            }
        };
        remove_other_vtk_files(run, &name, &pieces);
        self.pvd.remove_after(frame.time - 1e-12);
        for (part, file) in &pieces {
            self.pvd.push_part(frame.time, *part, file.clone());
        }
        self.pvd.write(&run.collection_path())?;
        Ok(pieces.into_iter().map(|(_, file)| file).collect())
    }
}

/// Removes the files of the frame whose whole VTK file is `whole` (its
/// name, `vtk/frame_NNNNN.vtp`) that `pieces` does not name: those an
/// earlier run wrote in more pieces, or whole, before a resume on another
/// rank count. Best effort: a stale file left behind is listed nowhere.
fn remove_other_vtk_files(run: &RunDirectory, whole: &str, pieces: &[(u32, String)]) {
    let whole_path = run.path().join(whole);
    let (Some(folder), Some(stem)) = (
        whole_path.parent(),
        whole_path.file_stem().and_then(|stem| stem.to_str()),
    ) else {
        return;
    };
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    let piece_prefix = format!("{stem}_part_");
    for entry in entries.flatten() {
        let path = entry.path();
        let Some(file) = path.file_name().and_then(|file| file.to_str()) else {
            continue;
        };
        let of_this_frame = file == format!("{stem}.vtp")
            || (file.starts_with(&piece_prefix) && file.ends_with(".vtp"));
        let kept = pieces
            .iter()
            .any(|(_, piece)| run.path().join(piece) == path);
        if of_this_frame && !kept {
            // Best effort, as said.
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// How the attributes the solver does not store are computed for output,
/// a particle at a time as they are written (no array of them is made).
struct DerivedAttributes<'a> {
    density: Box<dyn Fn(usize) -> f32 + Sync + 'a>,
    elastic_j: Box<dyn Fn(usize) -> f32 + Sync + 'a>,
    material: Box<dyn Fn(usize) -> u32 + Sync + 'a>,
}

/// Writes a snow frame with the scene's `[output] attributes`.
fn write_snow_frame(
    snow: SnowView<'_>,
    index: u32,
    run: &RunDirectory,
    collection: &mut Collection<'_>,
) -> Result<WrittenFrame, IoError> {
    let scene = snow.scene();
    let particles = snow.particles();
    let derived = DerivedAttributes::of(snow);
    let frame = snow_frame(snow, index, &derived, particles.len());
    let drift = scene.spindrift().map(|_| {
        let drift = snow.drift();
        FrameData::new(index, snow.time(), &drift.position)
            .with_attribute(Attribute::vector("velocity", &drift.velocity))
            .with_attribute(Attribute::scalar("mass", &drift.mass))
    });
    let formats = &scene.output.formats;
    let mut grids = Vec::new();
    if formats.contains(&CacheFormat::Vdb) {
        grids = scene_volumes(scene, particles);
        if scene.spindrift().is_some() {
            let drift = snow.drift();
            grids.push(drift_volume(scene, &drift.position, &drift.mass));
        }
    }
    let volumes = Volumes {
        grids,
        surface: formats
            .contains(&CacheFormat::Mesh)
            .then(|| scene_surface(scene, &particles.position, &particles.mass)),
    };
    let bodies = body_poses(snow);
    let written = FrameContents {
        frame: &frame,
        drift: drift.as_ref(),
        bodies: &bodies,
    };
    let mut files = write_caches(scene, written, &volumes, run, collection)?;
    if let Some(drift) = &drift {
        files.extend(write_drift_frame(scene, drift, run)?);
    }
    Ok(WrittenFrame {
        files,
        surface: volumes.surface,
    })
}

/// Writes the first `count` particles of `snow` (a rank's own, in a run
/// split between MPI ranks) at `path` as frame `index`'s VTK PolyData
/// piece, with the scene's `[output] attributes`, atomically.
pub fn write_snow_vtk_piece(
    snow: SnowView<'_>,
    count: usize,
    index: u32,
    path: &Path,
) -> Result<(), IoError> {
    let derived = DerivedAttributes::of(snow);
    write_vtp(path, &snow_frame(snow, index, &derived, count))
}

impl<'a> DerivedAttributes<'a> {
    /// The attributes of `snow`'s particles that it does not store:
    /// density, J_E and material as an unsigned integer.
    fn of(snow: SnowView<'a>) -> DerivedAttributes<'a> {
        let particles = snow.particles();
        DerivedAttributes {
            density: Box::new(|p| particles.density(p)),
            elastic_j: Box::new(|p| particles.elastic[p].determinant()),
            material: Box::new(|p| u32::from(particles.material[p])),
        }
    }
}

/// Frame `index` of the first `count` particles of `snow`, with the
/// scene's `[output] attributes`.
fn snow_frame<'a>(
    snow: SnowView<'a>,
    index: u32,
    derived: &'a DerivedAttributes<'a>,
    count: usize,
) -> FrameData<'a> {
    let particles = snow.particles();
    let mut frame = FrameData::new(index, snow.time(), &particles.position[..count]);
    for attribute in &snow.scene().output.attributes {
        frame = frame.with_attribute(attribute_data(*attribute, particles, derived, count));
    }
    frame
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

/// What a frame's caches hold besides the volumes: its particles, a
/// spindrift scene's drift and the rigid bodies' poses.
#[derive(Clone, Copy)]
struct FrameContents<'a> {
    frame: &'a FrameData<'a>,
    drift: Option<&'a FrameData<'a>>,
    bodies: &'a [BodyPose],
}

/// Writes `written.frame` in each of `scene`'s formats into `run`
/// (`volumes` for `vdb` and `mesh`, and a spindrift scene's drift and the
/// bodies for `usd`); returns the files' paths relative to the run
/// directory.
fn write_caches(
    scene: &Scene,
    written: FrameContents<'_>,
    volumes: &Volumes,
    run: &RunDirectory,
    collection: &mut Collection<'_>,
) -> Result<Vec<String>, IoError> {
    let FrameContents {
        frame,
        drift,
        bodies,
    } = written;
    let mut files = Vec::new();
    for &format in &scene.output.formats {
        let name = RunDirectory::cache_name(format, frame.index);
        let path = run.path().join(&name);
        match format {
            CacheFormat::Ply => write_ply(&path, frame)?,
            CacheFormat::Vtk => {
                files.extend(collection.write_vtk(frame, name, run)?);
                continue;
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
                if !bodies.is_empty() {
                    files.push(write_bodies_mesh(scene, frame.index, bodies, run)?);
                }
                continue;
            }
            CacheFormat::Usd => write_usd_frame(
                run.path(),
                &usd_stage(scene, frame.index),
                &[Some(frame), drift]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>(),
                UsdSolids {
                    colliders: &usd_collider_samples(scene, frame.time),
                    bodies: &usd_body_samples(scene, bodies),
                },
            )?,
        }
        files.push(name);
    }
    Ok(files)
}

/// Writes frame `index`'s rigid bodies at `poses` as one OBJ mesh beside
/// the snow's surface; returns its path relative to the run directory.
fn write_bodies_mesh(
    scene: &Scene,
    index: u32,
    poses: &[BodyPose],
    run: &RunDirectory,
) -> Result<String, IoError> {
    let mesh = bodies_mesh(scene, poses);
    let name = RunDirectory::bodies_obj_name(index);
    let data = MeshData {
        vertices: &mesh.vertices,
        triangles: &mesh.triangles,
    };
    write_mesh_obj(&run.path().join(&name), data)?;
    Ok(name)
}

/// The values of one cached attribute, of the first `count` particles.
fn attribute_data<'a>(
    attribute: SceneAttribute,
    particles: &'a Particles,
    derived: &'a DerivedAttributes<'a>,
    count: usize,
) -> Attribute<'a> {
    match attribute {
        SceneAttribute::Velocity => Attribute::vector("velocity", &particles.velocity[..count]),
        SceneAttribute::PlasticJ => Attribute::scalar("plastic_j", &particles.plastic_j[..count]),
        SceneAttribute::ElasticJ => {
            Attribute::computed_scalar("elastic_j", count, &*derived.elastic_j)
        }
        SceneAttribute::Density => Attribute::computed_scalar("density", count, &*derived.density),
        SceneAttribute::Mass => Attribute::scalar("mass", &particles.mass[..count]),
        SceneAttribute::Material => {
            Attribute::computed_integer("material", count, &*derived.material)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firn_core::scene::Body;
    use glam::Vec3;

    /// A ball of 8,000 cells of snow written as `formats`, the `vdb`
    /// voxels `voxel` metres.
    fn ball(formats: &[CacheFormat], voxel: Option<f32>) -> (Scene, WorkEstimate) {
        let mut scene = Scene::builder("ball")
            .unit_box(0.01)
            .body(Body::cuboid(Vec3::splat(0.5), Vec3::splat(0.2)))
            .formats(formats.iter().copied())
            .build()
            .unwrap();
        scene.output.vdb.voxel_size = voxel;
        let work = scene.estimate();
        (scene, work)
    }

    #[test]
    fn the_writers_hold_a_buffer_and_a_chunk_and_the_volumes_they_make() {
        let (scene, work) = ball(&[CacheFormat::Ply, CacheFormat::Usd], None);
        assert_eq!(work.particles, 64_000);
        let streams = writer_bytes(&scene, &work);
        assert_eq!(
            streams,
            (WRITE_BUFFER_BYTES + CHUNK_VALUES * 4 * 8) as u64,
            "position, velocity, plastic J and density stream a chunk at a time"
        );
        let (scene, work) = ball(&[CacheFormat::Ply, CacheFormat::Vdb], None);
        let with_vdb = writer_bytes(&scene, &work);
        assert_eq!(with_vdb - streams, 8000 * VDB_BYTES_PER_VOXEL);
        let (scene, work) = ball(&[CacheFormat::Ply, CacheFormat::Vdb], Some(0.005));
        assert_eq!(
            writer_bytes(&scene, &work) - streams,
            8 * 8000 * VDB_BYTES_PER_VOXEL
        );
    }
}
