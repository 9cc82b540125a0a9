//! Mesh colliders that deform: one mesh file per frame, as Blender's OBJ
//! exporter writes them with "Animation" on (`boot/frame_####.obj`).
//!
//! Every file has the same vertices and triangles in the same order; only
//! the positions change. Between two mesh frames each vertex moves in a
//! straight line, so its velocity over that interval is its displacement
//! times the sequence's frame rate. Before the first mesh frame the first
//! mesh holds still, after the last the last one does.
//!
//! The solver samples each mesh frame's signed distances in a narrow band
//! ([`firn_mesh::NarrowBandField`]) when the run reaches it; this module
//! only loads, checks and bounds the frames.

use std::path::{Path, PathBuf};

use firn_mesh::{
    BandFootprint, MeshError, MeshTransform, NarrowBandField, TriangleMesh, load_mesh,
};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::mesh::Derived;

/// Largest number of files a sequence may have.
pub const MAX_SEQUENCE_FRAMES: usize = 100_000;

/// A deforming mesh collider: its files, their timing and placement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshSequenceCollider {
    /// The pattern, with a run of `#` where the frame number goes
    /// (zero-padded to that many digits), resolved against the scene's
    /// folder.
    pub pattern: PathBuf,
    /// The number of the first file.
    pub first_number: u32,
    /// How many files there are, numbered consecutively.
    pub frame_count: u32,
    /// Mesh frames per second.
    pub frame_rate: f64,
    /// Simulated time of the first file, seconds.
    pub start: f64,
    /// Scale factors, applied first.
    pub scale: Vec3,
    /// Rotation in degrees about x, then y, then z, applied after scaling.
    pub rotation_degrees: Vec3,
    /// Where the first frame's bounding-box centre goes; `None` keeps the
    /// files' coordinates (after scale and rotation).
    pub center: Option<Vec3>,
    /// Spacing of the distance samples in metres.
    pub sdf_spacing: f32,
    /// How far from the surface the samples are exact, metres.
    pub band: f32,
    /// What the inspection of the first file found, one sentence each.
    pub warnings: Vec<String>,
    /// The placed vertex positions of every frame and the shared triangles.
    #[serde(skip)]
    pub frames: Derived<MeshFrames>,
}

/// The frames of a sequence, placed in the scene.
#[derive(Debug)]
pub struct MeshFrames {
    /// The triangles every frame shares.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex positions, one list per frame.
    pub positions: Vec<Vec<Vec3>>,
}

/// Where a time falls in a sequence: between mesh frames `from` and `to`
/// (equal before the first and after the last), a `fraction` of the way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SequenceInterval {
    /// The mesh frame before.
    pub from: usize,
    /// The mesh frame after.
    pub to: usize,
    /// How far from `from` to `to`, in [0, 1).
    pub fraction: f32,
}

impl MeshSequenceCollider {
    /// The band for a grid of `cell_size` and samples `spacing` apart:
    /// three grid cells, so that every grid node and particle the surface
    /// can reach in a substep reads exact distances, and at least two
    /// samples.
    pub fn band_for(cell_size: f32, spacing: f32) -> f32 {
        (3.0 * cell_size).max(2.0 * spacing)
    }

    /// Finds, loads and checks the files of `pattern` and places them.
    pub fn load(
        pattern: PathBuf,
        transform: (Vec3, Vec3, Option<Vec3>),
        timing: (f64, f64),
        sdf_spacing: f32,
        band: f32,
    ) -> Result<MeshSequenceCollider, MeshError> {
        let (scale, rotation_degrees, center) = transform;
        let (frame_rate, start) = timing;
        let (first_number, files) = sequence_files(&pattern)?;
        let mut sequence = MeshSequenceCollider {
            pattern,
            first_number,
            frame_count: files.len() as u32,
            frame_rate,
            start,
            scale,
            rotation_degrees,
            center,
            sdf_spacing,
            band,
            warnings: Vec::new(),
            frames: Derived::default(),
        };
        sequence.load_files(&files)?;
        Ok(sequence)
    }

    /// (Re)loads the frames from the files, as after reading the scene
    /// back from JSON.
    pub fn build(&mut self) -> Result<(), MeshError> {
        let (first_number, files) = sequence_files(&self.pattern)?;
        self.first_number = first_number;
        self.frame_count = files.len() as u32;
        self.load_files(&files)
    }

    fn load_files(&mut self, files: &[PathBuf]) -> Result<(), MeshError> {
        let rotation: Quat = crate::scene::motion::rotation_from_degrees(self.rotation_degrees);
        let orient = MeshTransform {
            scale: self.scale,
            rotation,
            translation: Vec3::ZERO,
        };
        let mut triangles = Vec::new();
        let mut positions = Vec::with_capacity(files.len());
        let mut offset = Vec3::ZERO;
        for (index, file) in files.iter().enumerate() {
            let loaded = load_mesh(file)?;
            let mesh = loaded.mesh.transformed(&orient);
            if index == 0 {
                self.warnings = loaded.diagnostics.warnings();
                if let Some(center) = self.center {
                    let (low, high) = mesh.bounds();
                    offset = center - 0.5 * (low + high);
                }
                triangles = mesh.triangles;
            } else if mesh.triangles != triangles
                || mesh.vertices.len() != positions_len(&positions)
            {
                return Err(topology_error(
                    file,
                    self.first_number as usize + index,
                    &mesh,
                    &triangles,
                    positions_len(&positions),
                ));
            }
            positions.push(mesh.vertices.into_iter().map(|v| v + offset).collect());
        }
        self.frames = Derived::new(MeshFrames {
            triangles,
            positions,
        });
        Ok(())
    }

    /// The same sequence cut to its first file: a mesh that holds still.
    pub fn first_frame_only(&self) -> MeshSequenceCollider {
        let frames = self.frames.get();
        MeshSequenceCollider {
            frame_count: 1,
            frames: Derived::new(MeshFrames {
                triangles: frames.triangles.clone(),
                positions: vec![frames.positions[0].clone()],
            }),
            ..self.clone()
        }
    }

    /// The simulated time of mesh frame `index` (counting from 0).
    pub fn time_of(&self, index: usize) -> f64 {
        self.start + index as f64 / self.frame_rate
    }

    /// Where simulated `time` falls between the mesh frames.
    pub fn interval_at(&self, time: f64) -> SequenceInterval {
        let last = self.frame_count.saturating_sub(1) as usize;
        let position = (time - self.start) * self.frame_rate;
        if position.is_nan() || position <= 0.0 {
            return SequenceInterval {
                from: 0,
                to: 0,
                fraction: 0.0,
            };
        }
        let from = position.floor();
        if from >= last as f64 {
            return SequenceInterval {
                from: last,
                to: last,
                fraction: 0.0,
            };
        }
        SequenceInterval {
            from: from as usize,
            to: from as usize + 1,
            fraction: (position - from) as f32,
        }
    }

    /// Every vertex's velocity between mesh frames `from` and `to` (zero
    /// when they are the same frame).
    pub fn vertex_velocities(&self, interval: SequenceInterval) -> Vec<Vec3> {
        let frames = self.frames.get();
        let rate = self.frame_rate as f32;
        frames.positions[interval.from]
            .iter()
            .zip(&frames.positions[interval.to])
            .map(|(&a, &b)| (b - a) * rate)
            .collect()
    }

    /// Mesh frame `index` as a triangle mesh.
    pub fn mesh_of(&self, index: usize) -> TriangleMesh {
        let frames = self.frames.get();
        TriangleMesh {
            vertices: frames.positions[index].clone(),
            triangles: frames.triangles.clone(),
        }
    }

    /// The mesh at simulated `time`, its vertices interpolated between the
    /// mesh frames around it.
    pub fn mesh_at(&self, time: f64) -> TriangleMesh {
        let frames = self.frames.get();
        let interval = self.interval_at(time);
        let vertices = frames.positions[interval.from]
            .iter()
            .zip(&frames.positions[interval.to])
            .map(|(&a, &b)| a.lerp(b, interval.fraction))
            .collect();
        TriangleMesh {
            vertices,
            triangles: frames.triangles.clone(),
        }
    }

    /// The narrow-band field of mesh frame `index`.
    pub fn field_of(&self, index: usize) -> NarrowBandField {
        NarrowBandField::build(&self.mesh_of(index), self.sdf_spacing, self.band)
    }

    /// The largest field of any frame and the samples of all of them
    /// together: the memory and the work of the run's rebuilds.
    pub fn footprint(&self) -> (BandFootprint, u64) {
        (0..self.frame_count as usize)
            .map(|index| {
                NarrowBandField::footprint(&self.mesh_of(index), self.sdf_spacing, self.band)
            })
            .fold((BandFootprint::default(), 0), |(largest, total), frame| {
                let largest = if frame.bytes() > largest.bytes() {
                    frame
                } else {
                    largest
                };
                (largest, total + frame.samples())
            })
    }

    /// The box every frame lies in.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.frames
            .get()
            .positions
            .iter()
            .flatten()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(low, high), &v| {
                (low.min(v), high.max(v))
            })
    }

    /// The first frame's bounding-box centre: the collider's reference point.
    pub fn reference_point(&self) -> Vec3 {
        let (low, high) = self.mesh_of(0).bounds();
        0.5 * (low + high)
    }
}

fn positions_len(positions: &[Vec<Vec3>]) -> usize {
    positions.first().map_or(0, Vec::len)
}

fn topology_error(
    file: &Path,
    number: usize,
    mesh: &TriangleMesh,
    triangles: &[[u32; 3]],
    vertices: usize,
) -> MeshError {
    MeshError {
        path: file.to_path_buf(),
        line: None,
        message: format!(
            "frame {number} has {} vertices and {} triangles{}, but the first frame has {vertices} \
             and {}",
            mesh.vertices.len(),
            mesh.triangles.len(),
            if mesh.triangles.len() == triangles.len() {
                " connected differently"
            } else {
                ""
            },
            triangles.len()
        ),
        hint: "export every frame from the same mesh without modifiers that change its topology \
               (in Blender: no remesh or decimate, \"Apply Modifiers\" the same for all frames)"
            .into(),
    }
}

/// The first number and the files of a pattern such as `frame_####.obj`,
/// numbered consecutively.
fn sequence_files(pattern: &Path) -> Result<(u32, Vec<PathBuf>), MeshError> {
    let error = |message: String, hint: &str| MeshError {
        path: pattern.to_path_buf(),
        line: None,
        message,
        hint: hint.into(),
    };
    let name = pattern
        .file_name()
        .and_then(|name| name.to_str())
        .unwrap_or_default();
    let Some(first_hash) = name.find('#') else {
        return Err(error(
            "the sequence's file name has no # for the frame number".into(),
            "write the frame number's digits as #s, e.g. boot/frame_####.obj for frame_0001.obj",
        ));
    };
    let width = name[first_hash..].chars().take_while(|&c| c == '#').count();
    let (prefix, suffix) = (&name[..first_hash], &name[first_hash + width..]);
    let folder = pattern
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let entries = std::fs::read_dir(folder).map_err(|err| {
        error(
            format!("cannot list the folder {}: {err}", folder.display()),
            "check that the folder exists and is readable",
        )
    })?;
    let mut numbers: Vec<u32> = entries
        .filter_map(|entry| entry.ok()?.file_name().into_string().ok())
        .filter_map(|file| {
            let digits = file.strip_prefix(prefix)?.strip_suffix(suffix)?;
            let digital = digits.len() >= width && digits.bytes().all(|b| b.is_ascii_digit());
            digital.then(|| digits.parse().ok()).flatten()
        })
        .collect();
    numbers.sort_unstable();
    numbers.dedup();
    let file_of = |number: u32| folder.join(format!("{prefix}{number:0width$}{suffix}"));
    let Some(&first) = numbers.first() else {
        return Err(error(
            format!("no file in {} matches {name}", folder.display()),
            "check the folder and the number of #s: frame_####.obj matches frame_0001.obj",
        ));
    };
    if numbers.len() > MAX_SEQUENCE_FRAMES {
        return Err(error(
            format!(
                "{} files match, more than {MAX_SEQUENCE_FRAMES}",
                numbers.len()
            ),
            "export fewer frames",
        ));
    }
    if let Some(gap) = numbers.windows(2).find(|pair| pair[1] != pair[0] + 1) {
        let missing = file_of(gap[0] + 1);
        return Err(MeshError {
            path: missing,
            line: None,
            message: format!(
                "frame {} of the sequence is missing: the files go from {first} to {} with a gap \
                 after {}",
                gap[0] + 1,
                numbers[numbers.len() - 1],
                gap[0]
            ),
            hint: "export the missing frame again, or renumber the files without gaps".into(),
        });
    }
    Ok((first, numbers.into_iter().map(file_of).collect()))
}
