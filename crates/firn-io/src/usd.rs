//! USD point caches (`.usda`): one stage per run that Houdini, Omniverse,
//! Blender and Pixar's own `usdview` open as a whole animation.
//!
//! No maintained Rust crate writes USD, and the binary crate format is
//! documented only by its C++ source; `usda` is USD's documented text
//! format, so this module writes that text itself.
//!
//! A run's particles are `UsdGeomPoints` prims, `/World/<name>` (the snow,
//! and the drift in the air where the scene has spindrift), each with
//! `points`, `velocities`, `extent` and one primvar per other cached
//! attribute, all time-sampled at the frame index as time code; its
//! colliders are `Mesh` (planes and mesh colliders), `Cube` (boxes),
//! `Cylinder` and `Sphere` prims moved by a time-sampled `xformOp:translate`
//! and, where they turn, turned by a time-sampled `xformOp:orient` (the
//! rotation about the reference point, applied before the translate); a
//! deforming mesh collider's `points` are time-sampled too, its triangles
//! written once. Its rigid bodies are prims of the same shapes,
//! `/World/Body<i>`, each with a time-sampled translate and orient.
//! Rewriting one file with every frame
//! would cost the whole run's data at each frame, so the samples are split
//! into USD *value clips*, one layer per frame ([`clip_name`]), which the
//! small stage file ([`STAGE_FILE`]) lists by a template: a frame writes its
//! own clip and rewrites the stage (a few kilobytes) with the new end time.
//! The bytes depend only on the frames, so a resumed run ends with the same
//! files as one never interrupted.

use std::fmt::Write as _;
use std::io;
use std::path::Path;

use glam::Vec3;

use crate::{AttributeValues, ColliderPose, FrameData, IoError, Values, write_atomically};

/// The stage file, relative to the run folder.
pub const STAGE_FILE: &str = "particles.usda";
/// The folder of the per-frame clip layers, relative to the run folder.
pub const CLIP_FOLDER: &str = "usd";
/// The clip manifest (the attributes the clips give values to), relative to
/// the run folder.
pub const MANIFEST_FILE: &str = "usd/manifest.usda";
/// The clips as USD's template (`#` stands for a digit of the frame index).
const CLIP_TEMPLATE: &str = "usd/frame.#####.usda";

/// Path of frame `index`'s clip layer, relative to the run folder (USD's
/// clip templates ask for `name.NNNNN.usda`).
pub fn clip_name(index: u32) -> String {
    format!("{CLIP_FOLDER}/frame.{index:05}.usda")
}

/// What the stage says of a run besides the particles.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdStage {
    /// The points prims, in the order of a frame's particle sets.
    pub points: Vec<UsdPoints>,
    /// Frames per second: the stage's time codes per second.
    pub fps: f64,
    /// The last frame written so far: the stage's end time code.
    pub last_frame: u32,
    /// The colliders, in the scene's order.
    pub colliders: Vec<UsdCollider>,
    /// The rigid bodies' shapes about their reference points, in the
    /// scene's order (never a deforming mesh).
    pub bodies: Vec<UsdShape>,
}

/// One collider prim of the stage.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdCollider {
    /// Its shape, about its reference point.
    pub shape: UsdShape,
    /// Whether it is ever turned: only then does the prim carry a
    /// time-sampled `xformOp:orient`.
    pub turns: bool,
}

/// One points prim of the stage.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdPoints {
    /// Name of the prim under `/World` (a USD identifier).
    pub name: String,
    /// Diameter drawn for each particle, in metres.
    pub width: f32,
}

/// A collider's shape about its reference point (the prim's translate).
#[derive(Clone, Debug, PartialEq)]
pub enum UsdShape {
    /// A square of half edge `half_size` through the point, facing `normal`.
    Plane {
        /// Unit normal of the free side.
        normal: Vec3,
        /// Half the square's edge in metres.
        half_size: f32,
    },
    /// A ball.
    Sphere {
        /// Radius in metres.
        radius: f32,
    },
    /// An axis-aligned box.
    Box {
        /// Edge lengths in metres.
        size: Vec3,
    },
    /// A cylinder about the y axis.
    Cylinder {
        /// Radius in metres.
        radius: f32,
        /// Length along the axis in metres.
        height: f32,
    },
    /// A capsule about the y axis.
    Capsule {
        /// Radius in metres.
        radius: f32,
        /// Whole length along the axis, end to end, in metres.
        height: f32,
    },
    /// A triangle mesh (a mesh collider's file, placed).
    Mesh {
        /// Vertex positions in metres, about the reference point.
        points: Vec<Vec3>,
        /// Triangles as indices into `points`, counter-clockwise seen from
        /// outside.
        triangles: Vec<[u32; 3]>,
    },
    /// A triangle mesh whose points move from frame to frame (a deforming
    /// mesh collider): each frame's clip gives them
    /// ([`UsdColliderSample::points`]).
    DeformingMesh {
        /// Triangles as indices into each frame's points, counter-clockwise
        /// seen from outside.
        triangles: Vec<[u32; 3]>,
    },
}

/// One collider's samples at a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdColliderSample {
    /// Where it is and how it is turned.
    pub pose: ColliderPose,
    /// A deforming mesh's points at the frame in metres, about its
    /// reference point; empty for every other collider.
    pub points: Vec<Vec3>,
}

/// A frame's samples of the stage's solids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UsdSolids<'a> {
    /// Each collider's samples, in the stage's order.
    pub colliders: &'a [UsdColliderSample],
    /// Where each rigid body's shape is and how it is turned about its
    /// reference point, in the stage's order.
    pub bodies: &'a [ColliderPose],
}

/// Writes a frame's clip into `folder` (the run folder), with `frames`
/// the particle sets of the stage's points prims in their order (of one
/// frame index) and the samples of the colliders and rigid bodies at that
/// frame in `solids`, then the clip manifest and the stage, each
/// atomically. Panics if `frames` and the stage's points prims, or the
/// solids' samples and its solid prims, differ in number.
pub fn write_usd_frame(
    folder: &Path,
    stage: &UsdStage,
    frames: &[&FrameData],
    solids: UsdSolids<'_>,
) -> Result<(), IoError> {
    let index = frames.first().map_or(0, |frame| frame.index);
    let path = folder.join(clip_name(index));
    assert_eq!(
        frames.len(),
        stage.points.len(),
        "one particle set per points prim"
    );
    assert_eq!(
        solids.colliders.len(),
        stage.colliders.len(),
        "one sample per collider prim"
    );
    assert_eq!(
        solids.bodies.len(),
        stage.bodies.len(),
        "one pose per body prim"
    );
    for frame in frames {
        frame.validate().map_err(|problem| IoError::InvalidFrame {
            path: path.clone(),
            problem,
        })?;
    }
    write_atomically(&path, |out| write_usd_clip(out, stage, frames, solids))?;
    let files = [
        (
            MANIFEST_FILE.to_string(),
            encode_usd_manifest(stage, frames),
        ),
        (STAGE_FILE.to_string(), encode_usd_stage(stage, frames)),
    ];
    for (name, text) in files {
        write_atomically(&folder.join(name), |out| out.write_all(text.as_bytes()))?;
    }
    Ok(())
}

/// One attribute of the points prim as USD declares it.
struct Declaration {
    /// The USD value type, e.g. `float[]`.
    type_name: &'static str,
    /// The attribute's name on the prim, e.g. `primvars:density`.
    name: String,
}

/// The time-sampled attributes of the points prim: positions, extent, then
/// one per cached attribute (`velocity` as UsdGeom's `velocities`).
fn declarations(frame: &FrameData) -> Vec<Declaration> {
    let mut list = vec![
        Declaration {
            type_name: "point3f[]",
            name: "points".to_string(),
        },
        Declaration {
            type_name: "float3[]",
            name: "extent".to_string(),
        },
    ];
    for attribute in &frame.attributes {
        let (type_name, name) = match attribute.values {
            AttributeValues::Vector(_) if attribute.name == "velocity" => {
                ("vector3f[]", "velocities".to_string())
            }
            AttributeValues::Vector(_) => ("vector3f[]", primvar_name(&attribute.name)),
            AttributeValues::Scalar(_) => ("float[]", primvar_name(&attribute.name)),
            AttributeValues::Integer(_) => ("int[]", primvar_name(&attribute.name)),
        };
        list.push(Declaration { type_name, name });
    }
    list
}

/// A cache attribute's primvar: `-` and `.` are not allowed in USD names.
fn primvar_name(attribute: &str) -> String {
    format!("primvars:{}", attribute.replace(['-', '.'], "_"))
}

/// The stage: metadata, the points prims' declarations (each from its
/// particle set in `frames`) and the colliders.
pub fn encode_usd_stage(stage: &UsdStage, frames: &[&FrameData]) -> String {
    let last = stage.last_frame;
    let mut text = String::new();
    // Writing into a String cannot fail.
    let _ = write!(
        text,
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    startTimeCode = 0\n    \
         endTimeCode = {last}\n    timeCodesPerSecond = {fps}\n    framesPerSecond = {fps}\n    \
         upAxis = \"Y\"\n    metersPerUnit = 1\n)\n\n\
         def Xform \"World\" (\n    clips = {{\n        dictionary default = {{\n            \
         string templateAssetPath = \"{CLIP_TEMPLATE}\"\n            \
         double templateStartTime = 0\n            double templateEndTime = {last}\n            \
         double templateStride = 1\n            \
         asset manifestAssetPath = @{MANIFEST_FILE}@\n            \
         string primPath = \"/World\"\n        }}\n    }}\n)\n{{\n",
        fps = stage.fps,
    );
    for (points, frame) in stage.points.iter().zip(frames) {
        push_points(&mut text, points, frame);
    }
    for (index, collider) in stage.colliders.iter().enumerate() {
        let name = format!("Collider{index}");
        push_solid(&mut text, &name, &collider.shape, collider.turns);
    }
    for (index, shape) in stage.bodies.iter().enumerate() {
        push_solid(&mut text, &format!("Body{index}"), shape, true);
    }
    text.push_str("}\n");
    text
}

/// A points prim's width and declarations, its samples left to the clips.
fn push_points(text: &mut String, points: &UsdPoints, frame: &FrameData) {
    let _ = write!(
        text,
        "    def Points \"{}\"\n    {{\n        float[] widths = [{}] (interpolation = \"constant\")\n",
        points.name, points.width
    );
    for declaration in declarations(frame) {
        let metadata = if declaration.name.starts_with("primvars:") {
            " (interpolation = \"vertex\")"
        } else {
            ""
        };
        let _ = writeln!(
            text,
            "        {} {}{metadata}",
            declaration.type_name, declaration.name
        );
    }
    text.push_str("    }\n");
}

/// A collider's or rigid body's prim named `name` of `shape`, its
/// translate (and orient, where it `turns`, and points, where it deforms)
/// left to the clips.
fn push_solid(text: &mut String, name: &str, shape: &UsdShape, turns: bool) {
    let (kind, body, scaled) = match shape {
        UsdShape::Plane { normal, half_size } => ("Mesh", plane_mesh(*normal, *half_size), false),
        UsdShape::Mesh { points, triangles } => ("Mesh", triangle_mesh(points, triangles), false),
        UsdShape::DeformingMesh { triangles } => ("Mesh", deforming_mesh(triangles), false),
        UsdShape::Sphere { radius } => (
            "Sphere",
            format!("        double radius = {radius}\n"),
            false,
        ),
        UsdShape::Box { .. } => ("Cube", "        double size = 1\n".to_string(), true),
        UsdShape::Cylinder { radius, height } => (
            "Cylinder",
            format!(
                "        uniform token axis = \"Y\"\n        double radius = {radius}\n        \
                 double height = {height}\n"
            ),
            false,
        ),
        // UsdGeomCapsule's height is the straight part between the caps.
        UsdShape::Capsule { radius, height } => (
            "Capsule",
            format!(
                "        uniform token axis = \"Y\"\n        double radius = {radius}\n        \
                 double height = {}\n",
                height - 2.0 * radius
            ),
            false,
        ),
    };
    let _ = write!(text, "    def {kind} \"{name}\"\n    {{\n{body}");
    let mut order = vec!["\"xformOp:translate\""];
    text.push_str("        double3 xformOp:translate\n");
    if turns {
        text.push_str("        quatf xformOp:orient\n");
        order.push("\"xformOp:orient\"");
    }
    if let (true, UsdShape::Box { size }) = (scaled, shape) {
        let _ = writeln!(text, "        float3 xformOp:scale = {}", tuple(*size));
        order.push("\"xformOp:scale\"");
    }
    let _ = writeln!(
        text,
        "        uniform token[] xformOpOrder = [{}]",
        order.join(", ")
    );
    text.push_str("    }\n");
}

/// A square quad through the origin facing `normal`, counter-clockwise seen
/// from the free side.
fn plane_mesh(normal: Vec3, half_size: f32) -> String {
    let (u, v) = normal.any_orthonormal_pair();
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(a, b)| tuple((u * a + v * b) * half_size));
    format!(
        "        int[] faceVertexCounts = [4]\n        int[] faceVertexIndices = [0, 1, 2, 3]\n        \
         point3f[] points = [{}]\n        uniform token subdivisionScheme = \"none\"\n",
        corners.join(", ")
    )
}

/// A triangle mesh's topology and points, as a `Mesh` prim's body.
fn triangle_mesh(points: &[Vec3], triangles: &[[u32; 3]]) -> String {
    format!(
        "{}        point3f[] points = {}\n        uniform token subdivisionScheme = \"none\"\n",
        topology(triangles),
        vectors(points)
    )
}

/// A deforming mesh's topology, as a `Mesh` prim's body: its points are
/// declared without a value, which would be stronger than the clips'.
fn deforming_mesh(triangles: &[[u32; 3]]) -> String {
    format!(
        "{}        point3f[] points\n        uniform token subdivisionScheme = \"none\"\n",
        topology(triangles)
    )
}

/// A triangle mesh's face counts and indices.
fn topology(triangles: &[[u32; 3]]) -> String {
    let counts = vec!["3"; triangles.len()].join(", ");
    let indices = list(triangles.iter().flatten());
    format!(
        "        int[] faceVertexCounts = [{counts}]\n        int[] faceVertexIndices = {indices}\n"
    )
}

/// The clip manifest: every attribute that the clips give samples to.
pub fn encode_usd_manifest(stage: &UsdStage, frames: &[&FrameData]) -> String {
    let mut text = String::from("#usda 1.0\n\nover \"World\"\n{\n");
    for (points, frame) in stage.points.iter().zip(frames) {
        let _ = write!(text, "    over \"{}\"\n    {{\n", points.name);
        for declaration in declarations(frame) {
            let _ = writeln!(
                text,
                "        {} {}",
                declaration.type_name, declaration.name
            );
        }
        text.push_str("    }\n");
    }
    for (index, collider) in stage.colliders.iter().enumerate() {
        let name = format!("Collider{index}");
        push_solid_over(&mut text, &name, collider.turns, deforms(collider));
    }
    for index in 0..stage.bodies.len() {
        push_solid_over(&mut text, &format!("Body{index}"), true, false);
    }
    text.push_str("}\n");
    text
}

/// The clip manifest's declarations of a solid prim named `name`: its
/// translate, its orient where it `turns`, its points where it `deforms`.
fn push_solid_over(text: &mut String, name: &str, turns: bool, deforms: bool) {
    let orient = if turns {
        "        quatf xformOp:orient\n"
    } else {
        ""
    };
    let points = if deforms {
        "        point3f[] points\n"
    } else {
        ""
    };
    let _ = write!(
        text,
        "    over \"{name}\"\n    {{\n        double3 xformOp:translate\n{orient}{points}    }}\n"
    );
}

/// Whether `collider` is a deforming mesh, whose clips carry its points.
fn deforms(collider: &UsdCollider) -> bool {
    matches!(collider.shape, UsdShape::DeformingMesh { .. })
}

/// A frame's clip: the samples of its particle sets `frames` (one per points
/// prim) and of the colliders and rigid bodies `solids` at its time code.
pub fn encode_usd_clip(stage: &UsdStage, frames: &[&FrameData], solids: UsdSolids<'_>) -> String {
    text_of(|out| write_usd_clip(out, stage, frames, solids))
}

/// Writes the clip of [`encode_usd_clip`] into `out`, a value at a time:
/// the text of a frame's particles is never held whole.
fn write_usd_clip(
    out: &mut dyn io::Write,
    stage: &UsdStage,
    frames: &[&FrameData],
    solids: UsdSolids<'_>,
) -> io::Result<()> {
    let code = frames.first().map_or(0, |frame| frame.index);
    out.write_all(b"#usda 1.0\n\nover \"World\"\n{\n")?;
    for (points, frame) in stage.points.iter().zip(frames) {
        write_samples(out, points, frame)?;
    }
    let colliders = stage.colliders.iter().zip(solids.colliders);
    for (index, (collider, sample)) in colliders.enumerate() {
        let name = format!("Collider{index}");
        write_pose(out, &name, code, &sample.pose, collider.turns)?;
        if deforms(collider) {
            write!(out, "        point3f[] points.timeSamples = {{ {code}: ")?;
            write_vectors(out, sample.points.iter().copied())?;
            out.write_all(b" }\n")?;
        }
        out.write_all(b"    }\n")?;
    }
    for (index, pose) in solids.bodies.iter().enumerate() {
        write_pose(out, &format!("Body{index}"), code, pose, true)?;
        out.write_all(b"    }\n")?;
    }
    out.write_all(b"}\n")
}

/// Opens the clip's `over` of the solid prim `name` with its translate at
/// time code `code` and, where it `turns`, its orient (the caller closes
/// it).
fn write_pose(
    out: &mut dyn io::Write,
    name: &str,
    code: u32,
    pose: &ColliderPose,
    turns: bool,
) -> io::Result<()> {
    write!(
        out,
        "    over \"{name}\"\n    {{\n        \
         double3 xformOp:translate.timeSamples = {{ {code}: {} }}\n",
        tuple(Vec3::from_array(pose.position))
    )?;
    if turns {
        // USD writes a quaternion real part first: (w, x, y, z).
        let [x, y, z, w] = pose.rotation;
        writeln!(
            out,
            "        quatf xformOp:orient.timeSamples = {{ {code}: ({w}, {x}, {y}, {z}) }}"
        )?;
    }
    Ok(())
}

/// A points prim's samples of `frame` at its time code.
fn write_samples(out: &mut dyn io::Write, points: &UsdPoints, frame: &FrameData) -> io::Result<()> {
    let code = frame.index;
    write!(out, "    over \"{}\"\n    {{\n", points.name)?;
    let mut declared = declarations(frame).into_iter();
    let mut next = || declared.next().expect("one declaration per sample");
    let (low, high) = extent(frame.positions, points.width * 0.5);
    write_sample(out, &next(), code, |out| {
        write_vectors(out, frame.positions.iter().copied())
    })?;
    write_sample(out, &next(), code, |out| {
        write!(out, "[{}, {}]", tuple(low), tuple(high))
    })?;
    for attribute in &frame.attributes {
        write_sample(out, &next(), code, |out| match attribute.values {
            AttributeValues::Vector(data) => write_vectors(out, each(data)),
            AttributeValues::Scalar(data) => write_list(out, each(data)),
            AttributeValues::Integer(data) => write_list(
                out,
                each(data).map(|n| i32::try_from(n).unwrap_or(i32::MAX)),
            ),
        })?;
    }
    out.write_all(b"    }\n")
}

/// One sample line: `declaration` at time code `code`, its value written
/// by `value`.
fn write_sample(
    out: &mut dyn io::Write,
    declaration: &Declaration,
    code: u32,
    value: impl FnOnce(&mut dyn io::Write) -> io::Result<()>,
) -> io::Result<()> {
    write!(
        out,
        "        {} {}.timeSamples = {{ {code}: ",
        declaration.type_name, declaration.name
    )?;
    value(out)?;
    out.write_all(b" }\n")
}

/// The values of `data` in order.
fn each<T: Copy>(data: Values<'_, T>) -> impl Iterator<Item = T> + '_ {
    (0..data.len()).map(move |index| data.get(index))
}

/// The bounds of `positions` grown by `margin` (zero where there are none).
fn extent(positions: &[Vec3], margin: f32) -> (Vec3, Vec3) {
    if positions.is_empty() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let (low, high) = positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(low, high), &p| (low.min(p), high.max(p)),
    );
    (low - margin, high + margin)
}

/// `(x, y, z)`, each the shortest text that reads back as the same f32.
fn tuple(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// `[(x, y, z), ...]`.
fn vectors(data: &[Vec3]) -> String {
    text_of(|out| write_vectors(out, data.iter().copied()))
}

/// `[a, b, ...]`.
fn list<T: std::fmt::Display>(data: impl Iterator<Item = T>) -> String {
    text_of(|out| write_list(out, data))
}

/// Writes `[(x, y, z), ...]`.
fn write_vectors(out: &mut dyn io::Write, data: impl Iterator<Item = Vec3>) -> io::Result<()> {
    out.write_all(b"[")?;
    for (index, v) in data.enumerate() {
        if index > 0 {
            out.write_all(b", ")?;
        }
        write!(out, "({}, {}, {})", v.x, v.y, v.z)?;
    }
    out.write_all(b"]")
}

/// Writes `[a, b, ...]`.
fn write_list<T: std::fmt::Display>(
    out: &mut dyn io::Write,
    data: impl Iterator<Item = T>,
) -> io::Result<()> {
    out.write_all(b"[")?;
    for (index, value) in data.enumerate() {
        if index > 0 {
            out.write_all(b", ")?;
        }
        write!(out, "{value}")?;
    }
    out.write_all(b"]")
}

/// The text that `write` writes (into memory, where it cannot fail).
fn text_of(write: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) -> String {
    let mut bytes = Vec::new();
    // Writing into a Vec cannot fail, and the writers write text only.
    let _ = write(&mut bytes);
    String::from_utf8(bytes).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Attribute;

    fn stage() -> UsdStage {
        UsdStage {
            points: vec![
                UsdPoints {
                    name: "Snow".to_string(),
                    width: 0.02,
                },
                UsdPoints {
                    name: "Drift".to_string(),
                    width: 0.01,
                },
            ],
            fps: 24.0,
            last_frame: 3,
            colliders: vec![
                UsdCollider {
                    shape: UsdShape::Plane {
                        normal: Vec3::Y,
                        half_size: 1.0,
                    },
                    turns: false,
                },
                UsdCollider {
                    shape: UsdShape::Box {
                        size: Vec3::new(1.0, 2.0, 3.0),
                    },
                    turns: true,
                },
            ],
            bodies: vec![UsdShape::Sphere { radius: 0.25 }],
        }
    }

    /// A rigid collider's sample at `position`, turned by `rotation`.
    fn pose(position: Vec3, rotation: glam::Quat) -> UsdColliderSample {
        UsdColliderSample {
            pose: ColliderPose {
                position: position.to_array(),
                rotation: rotation.to_array(),
            },
            points: Vec::new(),
        }
    }

    #[test]
    fn the_clip_holds_the_frame_samples_at_its_time_code() {
        let positions = [Vec3::new(0.5, 1.0, 0.25), Vec3::new(0.0, 0.1, 2.0)];
        let density = [400.0, 350.5];
        let frame = FrameData::new(3, 0.125, &positions)
            .with_attribute(Attribute::vector("velocity", &positions))
            .with_attribute(Attribute::scalar("plastic-j", &density));
        let drift = FrameData::new(3, 0.125, &positions[..1]);
        let quarter = glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let poses = [
            pose(Vec3::ZERO, glam::Quat::IDENTITY),
            pose(Vec3::X, quarter),
        ];
        let body = ColliderPose {
            position: [0.5, 2.0, 0.0],
            rotation: quarter.to_array(),
        };
        let solids = UsdSolids {
            colliders: &poses,
            bodies: &[body],
        };
        let clip = encode_usd_clip(&stage(), &[&frame, &drift], solids);
        assert!(
            clip.contains("point3f[] points.timeSamples = { 3: [(0.5, 1, 0.25), (0, 0.1, 2)] }")
        );
        assert!(clip.contains("vector3f[] velocities.timeSamples = { 3: ["));
        assert!(clip.contains("float[] primvars:plastic_j.timeSamples = { 3: [400, 350.5] }"));
        assert!(clip.contains("float3[] extent.timeSamples = { 3: [(-0.01, "));
        assert!(clip.contains("double3 xformOp:translate.timeSamples = { 3: (1, 0, 0) }"));
        let [x, y, z, w] = quarter.to_array();
        let orient = format!("quatf xformOp:orient.timeSamples = {{ 3: ({w}, {x}, {y}, {z}) }}");
        let plane = &clip[clip
            .find("over \"Collider0\"")
            .expect("the plane's samples")..];
        let turning = &clip[clip.find("over \"Collider1\"").expect("the box's samples")..];
        assert!(turning.contains(&orient), "{orient} missing from\n{clip}");
        assert!(
            !plane[..plane.find('}').unwrap()].contains("orient"),
            "an unturned collider has no orient: {plane}"
        );
        let body = &clip[clip.find("over \"Body0\"").expect("the body's samples")..];
        let body = &body[..body.find("    }\n").unwrap()];
        assert!(
            body.contains("double3 xformOp:translate.timeSamples = { 3: (0.5, 2, 0) }"),
            "{body}"
        );
        assert!(body.contains(&orient), "{orient} missing from\n{body}");
        let drift = &clip[clip.find("over \"Drift\"").expect("the drift's samples")..];
        assert!(drift.contains("point3f[] points.timeSamples = { 3: [(0.5, 1, 0.25)] }"));
        assert!(drift.contains("float3[] extent.timeSamples = { 3: [(0.495, 0.995, 0.245), "));
    }

    #[test]
    fn the_stage_names_the_range_the_clips_and_the_colliders() {
        let positions = [Vec3::ONE];
        let (snow, drift) = (
            FrameData::new(3, 0.125, &positions),
            FrameData::new(3, 0.125, &[]),
        );
        let text = encode_usd_stage(&stage(), &[&snow, &drift]);
        for line in [
            "endTimeCode = 3",
            "timeCodesPerSecond = 24",
            "upAxis = \"Y\"",
            "metersPerUnit = 1",
            "string templateAssetPath = \"usd/frame.#####.usda\"",
            "double templateEndTime = 3",
            "def Points \"Snow\"",
            "float[] widths = [0.02] (interpolation = \"constant\")",
            "def Points \"Drift\"",
            "float[] widths = [0.01] (interpolation = \"constant\")",
            "def Mesh \"Collider0\"",
            "def Cube \"Collider1\"",
            "def Sphere \"Body0\"",
            "float3 xformOp:scale = (1, 2, 3)",
            "uniform token[] xformOpOrder = [\"xformOp:translate\"]",
            "quatf xformOp:orient\n",
            "uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\", \
             \"xformOp:scale\"]",
        ] {
            assert!(text.contains(line), "{line} missing from\n{text}");
        }
        let manifest = encode_usd_manifest(&stage(), &[&snow, &drift]);
        let turning = &manifest[manifest.find("over \"Collider1\"").expect("the box")..];
        assert!(turning.contains("quatf xformOp:orient\n"), "{manifest}");
        let body = &manifest[manifest.find("over \"Body0\"").expect("the body")..];
        assert!(body.contains("quatf xformOp:orient\n"), "{manifest}");
        assert_eq!(manifest.matches("xformOp:orient").count(), 2, "{manifest}");
        assert_eq!(clip_name(3), "usd/frame.00003.usda");
    }

    #[test]
    fn a_deforming_mesh_has_its_points_in_every_clip_and_none_in_the_stage() {
        let triangle = [[0, 1, 2]];
        let stage = UsdStage {
            points: vec![UsdPoints {
                name: "Snow".to_string(),
                width: 0.02,
            }],
            fps: 24.0,
            last_frame: 2,
            colliders: vec![
                UsdCollider {
                    shape: UsdShape::Mesh {
                        points: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
                        triangles: triangle.to_vec(),
                    },
                    turns: false,
                },
                UsdCollider {
                    shape: UsdShape::DeformingMesh {
                        triangles: triangle.to_vec(),
                    },
                    turns: false,
                },
            ],
            bodies: Vec::new(),
        };
        let clip = |index: u32, lift: f32| {
            let frame = FrameData::new(index, index as f64 / 24.0, &[]);
            let mut samples = [
                pose(Vec3::ZERO, glam::Quat::IDENTITY),
                pose(Vec3::ONE, glam::Quat::IDENTITY),
            ];
            samples[1].points = vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, lift, 0.0)];
            let solids = UsdSolids {
                colliders: &samples,
                bodies: &[],
            };
            encode_usd_clip(&stage, &[&frame], solids)
        };
        for (index, lift, points) in [
            (1, 1.0, "[(0, 0, 0), (1, 0, 0), (0, 1, 0)]"),
            (2, 0.5, "[(0, 0, 0), (1, 0, 0), (0, 0.5, 0)]"),
        ] {
            let text = clip(index, lift);
            let rigid = &text[text.find("over \"Collider0\"").expect("the mesh")..];
            let deforming = &text[text.find("over \"Collider1\"").expect("the sequence")..];
            let line = format!("point3f[] points.timeSamples = {{ {index}: {points} }}");
            assert!(deforming.contains(&line), "{line} missing from\n{text}");
            assert!(
                !rigid[..rigid.find('}').unwrap()].contains("points"),
                "a rigid mesh's points are in the stage: {rigid}"
            );
        }
        let frame = FrameData::new(2, 2.0 / 24.0, &[]);
        let text = encode_usd_stage(&stage, &[&frame]);
        let deforming = &text[text.find("def Mesh \"Collider1\"").expect("the sequence")..];
        for line in [
            "int[] faceVertexIndices = [0, 1, 2]\n",
            "point3f[] points\n",
        ] {
            assert!(deforming.contains(line), "{line} missing from\n{text}");
        }
        let manifest = encode_usd_manifest(&stage, &[&frame]);
        let declared = &manifest[manifest.find("over \"Collider1\"").expect("the sequence")..];
        assert!(declared.contains("point3f[] points\n"), "{manifest}");
        assert_eq!(
            manifest.matches("point3f[] points").count(),
            2,
            "{manifest}"
        );
    }

    #[test]
    fn a_plane_quad_faces_its_normal() {
        let (u, v) = Vec3::Z.any_orthonormal_pair();
        assert!((u.cross(v) - Vec3::Z).length() < 1e-6);
        assert!(plane_mesh(Vec3::Z, 2.0).contains("faceVertexIndices = [0, 1, 2, 3]"));
    }
}
