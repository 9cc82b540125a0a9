//! Reads and checks the `[output]` table: cache directory, formats, attributes, VDB and mesh.

use std::path::PathBuf;

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{Num, ensure, first_duplicate, positive};
use crate::scene::flow::SceneKind;
use crate::scene::model::{Attribute, CacheFormat, MeshSettings, OutputSettings, VdbSettings};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    directory: Option<String>,
    formats: Option<Vec<RawFormat>>,
    attributes: Option<Vec<RawAttribute>>,
    checkpoint_every: Option<u32>,
    vdb: Option<RawVdb>,
    mesh: Option<RawMesh>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    voxel_size: Option<f32>,
    smoothing: Option<u32>,
    iso: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVdb {
    voxel_size: Option<f32>,
    level_set: Option<bool>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawFormat {
    Ply,
    Vtk,
    Vdb,
    Usd,
    Mesh,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawAttribute {
    Velocity,
    PlasticJ,
    ElasticJ,
    Density,
    Mass,
    Material,
}

/// The `[output]` table over [`OutputSettings::for_scene`]; the attributes
/// default to those of `kind`.
pub(super) fn resolve_output(
    raw: Option<RawOutput>,
    name: &str,
    kind: &SceneKind,
) -> OutputSettings {
    let defaults = OutputSettings {
        attributes: OutputSettings::default_attributes(kind),
        ..OutputSettings::for_scene(name)
    };
    let Some(raw) = raw else {
        return defaults;
    };
    let formats = raw.formats.map_or(defaults.formats, |formats| {
        formats
            .into_iter()
            .map(|format| match format {
                RawFormat::Ply => CacheFormat::Ply,
                RawFormat::Vtk => CacheFormat::Vtk,
                RawFormat::Vdb => CacheFormat::Vdb,
                RawFormat::Usd => CacheFormat::Usd,
                RawFormat::Mesh => CacheFormat::Mesh,
            })
            .collect()
    });
    let attributes = raw.attributes.map_or(defaults.attributes, |attributes| {
        attributes
            .into_iter()
            .map(|attribute| match attribute {
                RawAttribute::Velocity => Attribute::Velocity,
                RawAttribute::PlasticJ => Attribute::PlasticJ,
                RawAttribute::ElasticJ => Attribute::ElasticJ,
                RawAttribute::Density => Attribute::Density,
                RawAttribute::Mass => Attribute::Mass,
                RawAttribute::Material => Attribute::Material,
            })
            .collect()
    });
    OutputSettings {
        directory: raw.directory.map_or(defaults.directory, PathBuf::from),
        formats,
        attributes,
        checkpoint_every: raw.checkpoint_every.unwrap_or(defaults.checkpoint_every),
        vdb: raw.vdb.map_or(defaults.vdb, |vdb| VdbSettings {
            voxel_size: vdb.voxel_size,
            level_set: vdb.level_set.unwrap_or(false),
        }),
        mesh: raw.mesh.map_or(defaults.mesh, |mesh| MeshSettings {
            voxel_size: mesh.voxel_size,
            smoothing: mesh.smoothing.unwrap_or(MeshSettings::DEFAULT_SMOOTHING),
            iso: mesh.iso.unwrap_or(MeshSettings::DEFAULT_ISO),
        }),
    }
}

pub(super) fn check_output(output: &OutputSettings) -> Check {
    let path = KeyPath::of("output");
    if output.directory.as_os_str().is_empty() {
        return Err(Issue::new(
            path.key("directory"),
            "output.directory must not be empty",
            "name a directory, e.g. directory = \"out/snowball\", or remove the key",
        ));
    }
    if let Some(index) = first_duplicate(&output.formats) {
        let at = path.key("formats").index(index);
        return Err(Issue::new(
            at.clone(),
            format!("{at} lists a format twice"),
            "list each format once, e.g. formats = [\"ply\", \"vtk\"]",
        ));
    }
    if let Some(index) = first_duplicate(&output.attributes) {
        let at = path.key("attributes").index(index);
        return Err(Issue::new(
            at.clone(),
            format!("{at} lists an attribute twice"),
            "list each attribute once, e.g. attributes = [\"velocity\", \"plastic-j\", \
             \"density\"]",
        ));
    }
    Ok(())
}

/// Smallest `[output.vdb] voxel_size` as a fraction of the cell size: finer
/// voxels only blur single particles (and cost 8 leaves each).
const MIN_VOXELS_PER_CELL: f32 = 0.25;

pub(super) fn check_vdb(vdb: &VdbSettings, cell_size: f32) -> Check {
    match vdb.voxel_size {
        Some(voxel_size) => check_voxel_size(
            voxel_size,
            KeyPath::of("output").key("vdb").key("voxel_size"),
            cell_size,
        ),
        None => Ok(()),
    }
}

/// An `[output.vdb]` or `[output.mesh]` `voxel_size` at `path`: positive
/// and at least a quarter of the grid's cells.
fn check_voxel_size(voxel_size: f32, path: KeyPath, cell_size: f32) -> Check {
    let hint = format!(
        "set the voxel edge in metres, e.g. voxel_size = {}, or remove the key to use \
         domain.cell_size",
        Num::from(cell_size)
    );
    positive(voxel_size, path.clone(), hint.clone())?;
    let smallest = cell_size * MIN_VOXELS_PER_CELL;
    ensure(
        voxel_size >= smallest,
        path,
        &format!(
            "at least a quarter of domain.cell_size ({})",
            Num::from(smallest)
        ),
        Num::from(voxel_size),
        hint,
    )
}

/// Most `[output.mesh] smoothing` passes: beyond this the blur rounds the
/// snow off by more than a few cells and costs more than the reconstruction.
const MAX_MESH_SMOOTHING: u32 = 8;

pub(super) fn check_mesh(mesh: &MeshSettings, cell_size: f32) -> Check {
    let path = KeyPath::of("output").key("mesh");
    if let Some(voxel_size) = mesh.voxel_size {
        check_voxel_size(voxel_size, path.key("voxel_size"), cell_size)?;
    }
    ensure(
        mesh.smoothing <= MAX_MESH_SMOOTHING,
        path.key("smoothing"),
        &format!("at most {MAX_MESH_SMOOTHING} passes"),
        mesh.smoothing,
        "use a few passes, e.g. smoothing = 1 (0 for none)".to_string(),
    )?;
    ensure(
        mesh.iso > 0.0 && mesh.iso < 1.0,
        path.key("iso"),
        "a share of the rest density between 0 and 1 (exclusive)",
        Num::from(mesh.iso),
        "e.g. iso = 0.5: the surface lies where the snow is half as dense as at rest".to_string(),
    )
}
