//! The TOML scene format (`format = 1`).
//!
//! Loading happens in three passes over the text:
//!
//! 1. The text is parsed into a spanned TOML tree ([`toml::de::DeTable`]); syntax
//!    errors stop here, located by the parser.
//! 2. The text is deserialized into private raw structs that reject unknown
//!    keys (`deny_unknown_fields`) and wrong value types. The span that the
//!    TOML deserializer reports is turned into a key path (`bodies[1].radus`)
//!    by walking the spanned tree.
//! 3. Defaults and presets are resolved into the model types, and the model is
//!    checked by the same rules as [`Scene::validate`]. Those errors name a key
//!    path, which is looked up in the spanned tree to find the line and column
//!    of the offending value (or, for a missing key, of the table that should
//!    hold it).
//!
//! The model types stay free of spans; only this module knows about the text.
//! The format itself is documented in `docs/scene-format.md`.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::clumps::{Clumps, MAX_CONTRAST};
use super::compute::{Backend, ComputeSettings};
use super::estimate::{Bytes, CPU_BYTES_PER_PARTICLE, body_estimate};
use super::flow::SceneKind;
use super::material::{Material, PRESET_NAMES};
use super::mesh::{MeshBody, MeshCollider, MeshPlacement};
use super::model::{
    self, Attribute, Body, CacheFormat, Collider, ColliderGeometry, Contact, ContactMode, Domain,
    ImplicitSettings, Integrator, Keyframe, MeshSettings, Motion, OutputSettings, Scene, Shape,
    SolverSettings, TimeSettings, TimeStep, Transfer, VdbSettings,
};
use super::render::{Camera, CameraKey, ColorBy, Orbit, RenderSettings, RenderStyle};
use super::sampling;

mod flow;

pub use flow::MAX_FLOW_PARTICLES;

/// The only scene format version this build reads.
pub const FORMAT_VERSION: i64 = 1;

/// Largest number of grid cells allowed along one axis.
pub const MAX_CELLS_PER_AXIS: u64 = 1024;

/// Largest total number of grid cells allowed (2^30, a 1024³ box). The
/// solver's grid is sparse: the box costs a page table of 4 bytes per 4³
/// block (64 MiB at 1024³), node storage follows the snow.
pub const MAX_CELLS: u64 = 1 << 30;

/// `clumps.contrast` when a body's `clumps` table gives none.
pub const DEFAULT_CLUMP_CONTRAST: f32 = 0.15;

/// Largest `particles_per_cell` a body may ask for.
pub const MAX_PARTICLES_PER_CELL: u32 = 64;

/// Largest number of lattice points all bodies together may be filled from
/// (2^30). Each point is a candidate particle, tested once at the start, so
/// this bounds both the particles and the work of making them.
pub const MAX_LATTICE_POINTS: u64 = 1 << 30;

/// Most output frames a scene may have: frame numbers keep their five
/// digits in the cache and picture names, so the files sort.
pub const MAX_FRAMES: u32 = 99_999;

/// A problem with a scene: where it is, what is wrong, and how to fix it.
///
/// Displayed as one block in the style of rustc and cargo:
///
/// ```text
/// error: scenes/x.toml:12:9: domain.cell_size must be greater than 0 (got -0.1)
///   fix: set cell_size to the grid spacing in metres, e.g. cell_size = 0.02
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct SceneError {
    /// The scene file as the user named it; empty for a scene built in code.
    pub file: String,
    /// 1-based line of the offending text, if the error comes from a file.
    pub line: Option<usize>,
    /// 1-based column (in characters) of the offending text.
    pub column: Option<usize>,
    /// Key path of the offending value, e.g. `bodies[1].radius`.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (Some(line), Some(column)) => write!(f, "error: {}:{line}:{column}: ", self.file)?,
            (Some(line), None) => write!(f, "error: {}:{line}: ", self.file)?,
            _ => f.write_str("error: ")?,
        }
        f.write_str(&self.message)?;
        if !self.hint.is_empty() {
            write!(f, "\n  fix: {}", self.hint)?;
        }
        Ok(())
    }
}

// `SceneError` is a plain record of public fields (part of the API); it is
// returned once, on a cold path, so its size does not matter.
#[allow(clippy::result_large_err)]
impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|err| SceneError {
            message: format!("cannot read scene file '{file}': {err}"),
            file: file.clone(),
            line: None,
            column: None,
            key: None,
            hint: "check the path".to_string(),
        })?;
        Scene::from_toml_str(&text, &file)
    }

    /// Parse and validate scene text; `origin` names the file in messages.
    ///
    /// When the scene has no `name`, it is named after the file stem of
    /// `origin` if that ends in `.toml`, and `scene` otherwise.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let source = Source { text, origin };
        let doc = DeTable::parse(text).map_err(|err| source.syntax_error(&err))?;
        let root = Spanned::new(doc.span(), DeValue::Table(doc.into_inner()));

        check_format_version(&root).map_err(|issue| source.locate(&root, issue))?;
        let raw: RawScene =
            toml::from_str(text).map_err(|err| source.deserialize_error(&root, &err))?;
        let scene = resolve(raw, origin).map_err(|issue| source.locate(&root, issue))?;
        check_scene(&scene).map_err(|issue| source.locate(&root, issue))?;
        Ok(scene)
    }

    /// Check a scene built in code (same rules; errors carry the key path but no line).
    pub fn validate(&self) -> Result<(), SceneError> {
        check_scene(self).map_err(|issue| SceneError {
            file: String::new(),
            line: None,
            column: None,
            key: Some(issue.key.to_string()),
            message: issue.message,
            hint: issue.hint,
        })
    }
}

// ---------------------------------------------------------------------------
// Key paths and issues
// ---------------------------------------------------------------------------

/// One step of a key path: a table key or an array index.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Segment {
    Key(String),
    Index(usize),
}

/// A path to a value in the scene, like `bodies[1].radius`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct KeyPath(Vec<Segment>);

impl KeyPath {
    fn root() -> KeyPath {
        KeyPath(Vec::new())
    }

    fn of(key: &str) -> KeyPath {
        KeyPath::root().key(key)
    }

    fn key(&self, key: &str) -> KeyPath {
        let mut path = self.clone();
        path.0.push(Segment::Key(key.to_string()));
        path
    }

    fn index(&self, index: usize) -> KeyPath {
        let mut path = self.clone();
        path.0.push(Segment::Index(index));
        path
    }

    fn parent(&self) -> KeyPath {
        let mut path = self.clone();
        path.0.pop();
        path
    }

    /// The last table key in the path, if any.
    fn leaf(&self) -> Option<&str> {
        match self.0.last() {
            Some(Segment::Key(key)) => Some(key),
            _ => None,
        }
    }

    fn is_root(&self) -> bool {
        self.0.is_empty()
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, segment) in self.0.iter().enumerate() {
            match segment {
                Segment::Index(index) => write!(f, "[{index}]")?,
                Segment::Key(key) => {
                    if i > 0 {
                        f.write_str(".")?;
                    }
                    let bare = !key.is_empty()
                        && key
                            .chars()
                            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
                    if bare {
                        f.write_str(key)?;
                    } else {
                        write!(f, "{key:?}")?;
                    }
                }
            }
        }
        Ok(())
    }
}

/// A problem found while resolving or checking a scene, before it is placed
/// in the text.
#[derive(Debug)]
struct Issue {
    /// The key the problem is about.
    key: KeyPath,
    /// Where to point in the text, if not at `key` itself.
    at: Option<KeyPath>,
    message: String,
    hint: String,
}

impl Issue {
    fn new(key: KeyPath, message: impl Into<String>, hint: impl Into<String>) -> Issue {
        Issue {
            key,
            at: None,
            message: message.into(),
            hint: hint.into(),
        }
    }

    /// Replace the hint.
    fn with_hint(mut self, hint: &str) -> Issue {
        self.hint = hint.to_string();
        self
    }

    /// Point at `at` in the text instead of at the key.
    fn pointing_at(mut self, at: KeyPath) -> Issue {
        self.at = Some(at);
        self
    }
}

type Check = Result<(), Issue>;

// ---------------------------------------------------------------------------
// Locating issues in the text
// ---------------------------------------------------------------------------

/// The scene text and the name it is reported under.
struct Source<'a> {
    text: &'a str,
    origin: &'a str,
}

impl Source<'_> {
    /// 1-based line and column (in characters) of a byte offset.
    fn line_column(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        (line, column)
    }

    fn error_at(
        &self,
        offset: usize,
        key: Option<String>,
        message: String,
        hint: String,
    ) -> SceneError {
        let (line, column) = self.line_column(offset);
        SceneError {
            file: self.origin.to_string(),
            line: Some(line),
            column: Some(column),
            key,
            message,
            hint,
        }
    }

    /// Place an issue at the value its path names, or at the nearest enclosing
    /// table that exists in the text.
    fn locate(&self, root: &Spanned<DeValue<'_>>, issue: Issue) -> SceneError {
        let at = issue.at.as_ref().unwrap_or(&issue.key);
        let offset = span_of_path(root, at).start;
        self.error_at(
            offset,
            Some(issue.key.to_string()),
            issue.message,
            issue.hint,
        )
    }

    fn syntax_error(&self, err: &toml::de::Error) -> SceneError {
        let offset = err.span().map_or(0, |span| span.start);
        let message = err.message().trim_end();
        let hint = if message.contains("duplicate") {
            "each key and each [table] may appear only once; merge the two definitions"
        } else {
            "fix the TOML syntax at this point (strings need quotes, tables are written \
             [name] or [[name]], arrays [a, b, c])"
        };
        self.error_at(
            offset,
            None,
            format!("invalid TOML: {message}"),
            hint.to_string(),
        )
    }

    /// Turn a deserialization error (unknown key, wrong type, ...) into a
    /// located error with a readable message.
    fn deserialize_error(&self, root: &Spanned<DeValue<'_>>, err: &toml::de::Error) -> SceneError {
        let span = err.span().unwrap_or(0..0);
        let mut path = path_at_offset(root, span.start).unwrap_or_default();
        // An [[array]] header spans both the array and its first element; an
        // array where a table belongs is about the array.
        if err.message().starts_with("invalid type: sequence")
            && matches!(path.0.last(), Some(Segment::Index(_)))
        {
            path = path.parent();
        }
        let (message, hint) = describe_deserialize_error(err.message(), &path);
        let key = (!path.is_root()).then(|| path.to_string());
        self.error_at(span.start, key, message, hint)
    }
}

/// Span of the value at `path`, or of the deepest part of it that exists.
/// Tables written as `[header]` have the span of their header; the root table
/// and anything missing from the text fall back to the start of the file.
fn span_of_path(root: &Spanned<DeValue<'_>>, path: &KeyPath) -> Range<usize> {
    let mut node = root;
    for segment in &path.0 {
        let next = match (segment, node.get_ref()) {
            (Segment::Key(key), DeValue::Table(table)) => table.get(key.as_str()),
            (Segment::Index(index), DeValue::Array(array)) => array.get(*index),
            _ => None,
        };
        match next {
            Some(next) => node = next,
            None => break,
        }
    }
    node.span()
}

/// The key path of the deepest key or value whose span contains `offset`.
fn path_at_offset(root: &Spanned<DeValue<'_>>, offset: usize) -> Option<KeyPath> {
    fn covers(span: &Range<usize>, offset: usize) -> bool {
        span.start <= offset && offset < span.end.max(span.start + 1)
    }

    fn search(node: &Spanned<DeValue<'_>>, path: &KeyPath, offset: usize) -> Option<KeyPath> {
        // Table headers do not cover their keys, so every child is searched.
        match node.get_ref() {
            DeValue::Table(table) => {
                for (key, value) in table.iter() {
                    let child = path.key(key.get_ref());
                    if covers(&key.span(), offset) {
                        return Some(child);
                    }
                    if let Some(found) = search(value, &child, offset) {
                        return Some(found);
                    }
                }
            }
            DeValue::Array(array) => {
                for (index, value) in array.iter().enumerate() {
                    if let Some(found) = search(value, &path.index(index), offset) {
                        return Some(found);
                    }
                }
            }
            _ => {}
        }
        covers(&node.span(), offset).then(|| path.clone())
    }

    search(root, &KeyPath::root(), offset)
}

/// Reword the deserializer's message for a user, with a hint.
fn describe_deserialize_error(message: &str, path: &KeyPath) -> (String, String) {
    let quoted = backticked(message);
    if message.starts_with("unknown field") {
        let unknown = quoted.first().cloned().unwrap_or_default();
        let expected: Vec<&str> = quoted.iter().skip(1).map(String::as_str).collect();
        let parent = path.parent();
        let place = if parent.is_root() {
            "at the top level".to_string()
        } else {
            format!("in {parent}")
        };
        let mut hint = String::new();
        if !parent.is_root()
            && (unknown == "format"
                || unknown == "name"
                || unknown == "kind"
                || TABLES.contains(&unknown.as_str()))
        {
            // The header the key was written under: [name] or [[name]].
            let header = match (parent.0.first(), parent.0.get(1)) {
                (Some(Segment::Key(key)), Some(Segment::Index(_))) => format!("[[{key}]]"),
                (Some(Segment::Key(key)), _) => format!("[{key}]"),
                _ => "a table header".to_string(),
            };
            return (
                format!("unknown key `{unknown}` {place}"),
                format!(
                    "`{unknown}` is a top-level key: move it above the first [table] header, \
                     since the keys after {header} belong to that table"
                ),
            );
        }
        if let Some(best) = closest(&unknown, &expected) {
            hint.push_str(&format!("did you mean `{best}`? "));
        }
        if expected.is_empty() {
            hint.push_str("remove this key");
        } else {
            hint.push_str(&format!("expected one of {}", expected.join(", ")));
        }
        return (format!("unknown key `{unknown}` {place}"), hint);
    }
    if message.starts_with("unknown variant") {
        let unknown = quoted.first().cloned().unwrap_or_default();
        let expected: Vec<&str> = quoted.iter().skip(1).map(String::as_str).collect();
        let mut hint = String::new();
        if let Some(best) = closest(&unknown, &expected) {
            hint.push_str(&format!("did you mean \"{best}\"? "));
        }
        let choices: Vec<String> = expected.iter().map(|e| format!("\"{e}\"")).collect();
        // For an element of a list, name the list.
        let mut list = path.clone();
        while let Some(Segment::Index(_)) = list.0.last() {
            list.0.pop();
        }
        hint.push_str(&format!("{list} takes one of {}", choices.join(", ")));
        return (format!("{path} has no option \"{unknown}\""), hint);
    }
    if let Some(rest) = message
        .strip_prefix("invalid type: ")
        .or_else(|| message.strip_prefix("invalid value: "))
    {
        let (found, expected) = rest.split_once(", expected ").unwrap_or((rest, ""));
        let wanted = describe_expected(expected, path);
        return (
            format!("{path} must be {wanted}, not {}", describe_found(found)),
            example_hint(path, &wanted),
        );
    }
    if let Some(rest) = message.strip_prefix("invalid length ") {
        let (found, expected) = rest.split_once(", expected ").unwrap_or((rest, ""));
        let wanted = describe_expected(expected, path);
        return (
            format!("{path} must be {wanted}, but it has {found} elements"),
            example_hint(path, &wanted),
        );
    }
    if message.starts_with("duplicate key") {
        return (
            format!("{path} is set twice"),
            "keep only one of the two definitions".to_string(),
        );
    }
    (
        if path.is_root() {
            message.to_string()
        } else {
            format!("{path}: {message}")
        },
        "see docs/scene-format.md for the keys and values a scene file takes".to_string(),
    )
}

/// Plain words for serde's description of the value found.
fn describe_found(found: &str) -> String {
    let inner = backticked(found).into_iter().next();
    match (found.split([' ', '`']).next().unwrap_or(""), inner) {
        ("integer" | "floating" | "boolean", Some(value)) => value,
        ("string", _) => format!("the {found}"),
        ("sequence", _) => "an array".to_string(),
        ("map", _) => "a table".to_string(),
        _ => found.to_string(),
    }
}

/// Words between backticks, in order.
fn backticked(message: &str) -> Vec<String> {
    message
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// Plain words for serde's "expected ..." descriptions.
fn describe_expected(expected: &str, path: &KeyPath) -> String {
    if path.is_root() || path.0.len() == 1 && TABLES.contains(&path.leaf().unwrap_or("")) {
        return match path.leaf() {
            Some("bodies") | Some("colliders") => "an array of tables".to_string(),
            _ => "a table".to_string(),
        };
    }
    match expected {
        "f32" | "f64" => "a number".to_string(),
        "u32" | "u64" => "a whole number, 0 or more".to_string(),
        "i64" => "a whole number".to_string(),
        "a string" => "a string".to_string(),
        "a boolean" => "true or false".to_string(),
        "an array of length 3" => "an array of 3 numbers [x, y, z]".to_string(),
        "a sequence" => "an array".to_string(),
        "a map" => "a table".to_string(),
        e if e.starts_with("struct ") => "a table".to_string(),
        e if e.contains("variant") => "a string naming one of the options".to_string(),
        e => e.to_string(),
    }
}

/// Top-level tables of the format.
const TABLES: [&str; 9] = [
    "domain",
    "time",
    "solver",
    "materials",
    "bodies",
    "colliders",
    "output",
    "flow",
    "compute",
];

/// "write it as ..., e.g. key = value".
fn example_hint(path: &KeyPath, wanted: &str) -> String {
    if let Some(Segment::Key(first)) = path.0.first()
        && first == "materials"
        && path.0.len() == 2
    {
        return "write each material as a [materials.NAME] table, e.g. [materials.wet] \
                followed by density = 600.0"
            .to_string();
    }
    let Some(leaf) = path.leaf() else {
        return format!("write {wanted} here");
    };
    if path.0.len() == 1 && TABLES.contains(&leaf) {
        return match leaf {
            "bodies" | "colliders" => {
                format!("write each entry as its own [[{leaf}]] table")
            }
            "materials" => "write each material as a [materials.NAME] table".to_string(),
            _ => format!("write [{leaf}] on its own line, followed by its keys"),
        };
    }
    match example(leaf) {
        Some(example) => format!("{leaf} takes {wanted}, e.g. {example}"),
        None => format!("{leaf} takes {wanted}"),
    }
}

/// An example line for a key, used in hints.
fn example(leaf: &str) -> Option<&'static str> {
    Some(match leaf {
        "format" => "format = 1",
        "name" => "name = \"snowball\"",
        "min" => "min = [0.0, 0.0, 0.0]",
        "max" => "max = [2.0, 2.0, 2.0]",
        "cell_size" => "cell_size = 0.02",
        "walls" => "walls = { mode = \"separate\", friction = 0.2 }",
        "mode" => "mode = \"separate\"",
        "friction" => "friction = 0.2",
        "duration" => "duration = 2.0",
        "fps" => "fps = 30",
        "step" => "step = \"adaptive\"",
        "dt" => "dt = 0.001",
        "cfl" => "cfl = 0.4",
        "max_substeps_per_frame" => "max_substeps_per_frame = 100000",
        "transfer" => "transfer = \"pic-flip\"",
        "flip" => "flip = 0.95",
        "gravity" => "gravity = [0.0, -9.81, 0.0]",
        "seed" => "seed = 1",
        "integrator" => "integrator = \"semi-implicit\"",
        "implicit_beta" => "implicit_beta = 0.5",
        "solver_tolerance" => "solver_tolerance = 1e-3",
        "solver_max_iterations" => "solver_max_iterations = 100",
        "preset" => "preset = \"snow\"",
        "youngs_modulus" => "youngs_modulus = 1.4e5",
        "poisson_ratio" => "poisson_ratio = 0.2",
        "hardening" => "hardening = 10.0",
        "critical_compression" => "critical_compression = 0.025",
        "critical_stretch" => "critical_stretch = 0.0075",
        "density" => "density = 400.0",
        "shape" => "shape = \"sphere\"",
        "center" => "center = [1.0, 0.5, 1.0]",
        "radius" => "radius = 0.1",
        "size" => "size = [0.2, 0.2, 0.2]",
        "height" => "height = 0.5",
        "axis" => "axis = [0.0, 1.0, 0.0]",
        "velocity" => "velocity = [0.0, 0.0, 0.0]",
        "material" => "material = \"snow\"",
        "particles_per_cell" => "particles_per_cell = 8",
        "clumps" => "clumps = { size = 0.05, contrast = 0.15 }",
        "mesh" => "mesh = \"../assets/meshes/bunny.obj\"",
        "scale" => "scale = 2.0",
        "rotation" => "rotation = [0.0, 90.0, 0.0]",
        "sdf_spacing" => "sdf_spacing = 0.01",
        "point" => "point = [0.0, 0.0, 0.0]",
        "normal" => "normal = [0.0, 1.0, 0.0]",
        "keyframes" => {
            "keyframes = [{ time = 0.0, position = [1.0, 0.5, 1.0] }, \
             { time = 1.0, position = [1.0, 1.5, 1.0] }]"
        }
        "time" => "time = 0.5",
        "position" => "position = [1.0, 0.5, 1.0]",
        "directory" => "directory = \"out/snowball\"",
        "formats" => "formats = [\"ply\", \"vtk\", \"vdb\"]",
        "attributes" => "attributes = [\"velocity\", \"plastic-j\", \"density\"]",
        "checkpoint_every" => "checkpoint_every = 10",
        "vdb" => "vdb = { voxel_size = 0.02, level_set = true }",
        "voxel_size" => "voxel_size = 0.02",
        "level_set" => "level_set = true",
        "smoothing" => "smoothing = 1",
        "iso" => "iso = 0.5",
        "look_at" => "look_at = [1.0, 0.3, 1.0]",
        "fov" => "fov = 40.0",
        "orbit" => "orbit = 30.0",
        "path" => "path = [{ time = 0.0, position = [3.0, 1.0, 3.0], look_at = [1.0, 0.3, 1.0] }]",
        "enabled" => "enabled = true",
        "styles" => "styles = [\"points\", \"volume\"]",
        "color_by" => "color_by = \"density\"",
        "legend" => "legend = true",
        "point_radius" => "point_radius = 0.005",
        "trail_length" => "trail_length = 16",
        "smooth_trails" => "smooth_trails = true",
        "kind" => "kind = \"flow\"",
        "noise_share" => "noise_share = 0.5",
        "noise_strength" => "noise_strength = 5.0",
        "length_scale" => "length_scale = 20.0",
        "background_direction" => "background_direction = [1.0, 0.0, 0.0]",
        "background_strength" => "background_strength = 1.0",
        "speed_scale" => "speed_scale = 1.0",
        "offsets" => "offsets = [[0.0, 0.0, 0.0], [517.0, -233.0, 71.0], [-89.0, 401.0, -350.0]]",
        "evolution_rate" => "evolution_rate = 0.05",
        "curl" => "curl = \"analytic\"",
        "curl_step" => "curl_step = 0.02",
        "integration" => "integration = \"rk2\"",
        "substeps" => "substeps = 2",
        "influence" => "influence = 10.0",
        "rate" => "rate = 1000.0",
        "count" => "count = 10000",
        "lifetime" => "lifetime = 8.0",
        "lifetime_spread" => "lifetime_spread = 0.25",
        "velocity_decay" => "velocity_decay = 1.0",
        "backend" => "backend = \"auto\"",
        _ => return None,
    })
}

/// The candidate closest to `word` by edit distance, if it is close enough to
/// be a likely typo.
fn closest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .iter()
        .map(|candidate| (edit_distance(word, candidate), *candidate))
        .filter(|(distance, _)| *distance <= limit)
        .min_by_key(|(distance, _)| *distance)
        .map(|(_, candidate)| candidate)
}

/// Levenshtein distance over characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut current = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let substitute = previous[j] + usize::from(ca != *cb);
            current[j + 1] = substitute.min(previous[j + 1] + 1).min(current[j] + 1);
        }
        previous = current;
    }
    previous[b.len()]
}

// ---------------------------------------------------------------------------
// Raw structs: the file as written
// ---------------------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    format: Option<i64>,
    name: Option<String>,
    domain: Option<RawDomain>,
    time: Option<RawTime>,
    solver: Option<RawSolver>,
    materials: Option<BTreeMap<String, RawMaterial>>,
    bodies: Option<Vec<RawBody>>,
    colliders: Option<Vec<RawCollider>>,
    output: Option<RawOutput>,
    camera: Option<RawCamera>,
    render: Option<RawRender>,
    kind: Option<flow::RawKind>,
    flow: Option<flow::RawFlow>,
    wind: Option<flow::RawFlow>,
    compute: Option<RawCompute>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCompute {
    backend: Option<Backend>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDomain {
    min: Option<[f32; 3]>,
    max: Option<[f32; 3]>,
    cell_size: Option<f32>,
    walls: Option<RawContact>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawContact {
    mode: Option<RawMode>,
    friction: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawMode {
    Sticky,
    Slip,
    Separate,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTime {
    duration: Option<f64>,
    fps: Option<f64>,
    step: Option<RawStep>,
    dt: Option<f32>,
    cfl: Option<f32>,
    max_substeps_per_frame: Option<u32>,
}

#[derive(Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawStep {
    Adaptive,
    Fixed,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSolver {
    transfer: Option<RawTransfer>,
    flip: Option<f32>,
    gravity: Option<[f32; 3]>,
    seed: Option<u64>,
    integrator: Option<RawIntegrator>,
    implicit_beta: Option<f32>,
    solver_tolerance: Option<f32>,
    solver_max_iterations: Option<u32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawIntegrator {
    Explicit,
    SemiImplicit,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawTransfer {
    PicFlip,
    Apic,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    preset: Option<String>,
    youngs_modulus: Option<f32>,
    poisson_ratio: Option<f32>,
    hardening: Option<f32>,
    critical_compression: Option<f32>,
    critical_stretch: Option<f32>,
    density: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBody {
    shape: Option<RawBodyShape>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    height: Option<f32>,
    axis: Option<[f32; 3]>,
    velocity: Option<[f32; 3]>,
    material: Option<String>,
    particles_per_cell: Option<u32>,
    mesh: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    clumps: Option<RawClumps>,
}

/// A body's `clumps = { size, contrast }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawClumps {
    size: Option<f32>,
    contrast: Option<f32>,
}

/// A mesh's scale: one factor for all axes or one per axis.
#[derive(Clone, Copy, Deserialize)]
#[serde(untagged)]
enum RawScale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawBodyShape {
    Sphere,
    Box,
    Cylinder,
    Mesh,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCollider {
    shape: Option<RawColliderShape>,
    point: Option<[f32; 3]>,
    normal: Option<[f32; 3]>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    mode: Option<RawMode>,
    friction: Option<f32>,
    velocity: Option<[f32; 3]>,
    keyframes: Option<Vec<RawKeyframe>>,
    mesh: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    sdf_spacing: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawColliderShape {
    Plane,
    Sphere,
    Box,
    Mesh,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeyframe {
    time: Option<f64>,
    position: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
    fov: Option<f32>,
    orbit: Option<f32>,
    path: Option<Vec<RawCameraKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCameraKey {
    time: Option<f64>,
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRender {
    enabled: Option<bool>,
    styles: Option<Vec<RenderStyle>>,
    size: Option<[u32; 2]>,
    color_by: Option<ColorBy>,
    legend: Option<bool>,
    point_radius: Option<f32>,
    trail_length: Option<u32>,
    smooth_trails: Option<bool>,
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

// ---------------------------------------------------------------------------
// Resolution: defaults and presets
// ---------------------------------------------------------------------------

/// Check `format` before anything else, so that a file written for another
/// version gets that message rather than one about unknown keys.
fn check_format_version(root: &Spanned<DeValue<'_>>) -> Check {
    let DeValue::Table(table) = root.get_ref() else {
        return Ok(());
    };
    let path = KeyPath::of("format");
    let Some(value) = table.get("format") else {
        return Err(Issue::new(
            path,
            "the scene file has no `format` key",
            "add `format = 1` as the first line of the file",
        ));
    };
    let version = match value.get_ref() {
        DeValue::Integer(integer) => {
            let digits: String = integer.as_str().chars().filter(|c| *c != '_').collect();
            i64::from_str_radix(&digits, integer.radix()).ok()
        }
        _ => None,
    };
    if version == Some(FORMAT_VERSION) {
        return Ok(());
    }
    let written = match version {
        Some(version) => version.to_string(),
        None => "a value that is not a whole number".to_string(),
    };
    Err(Issue::new(
        path,
        format!("this firn reads format {FORMAT_VERSION}, but the file says format = {written}"),
        format!(
            "write `format = {FORMAT_VERSION}` and use the keys described in docs/scene-format.md"
        ),
    ))
}

fn missing(key: KeyPath, what: &str) -> Issue {
    let leaf = key.leaf().unwrap_or("").to_string();
    let hint = match example(&leaf) {
        Some(example) => format!("add {what}, e.g. {example}"),
        None => format!("add {what}"),
    };
    let table = key.parent();
    let message = if table.is_root() {
        format!("the scene needs `{leaf}`")
    } else {
        format!("{table} needs `{leaf}`")
    };
    Issue::new(key.clone(), message, hint).pointing_at(table)
}

fn require<T>(value: Option<T>, key: KeyPath, what: &str) -> Result<T, Issue> {
    value.ok_or_else(|| missing(key, what))
}

/// Error for a key that the chosen shape does not take.
fn reject<T>(value: &Option<T>, key: KeyPath, shape: &str, takes: &str) -> Check {
    if value.is_none() {
        return Ok(());
    }
    let leaf = key.leaf().unwrap_or("").to_string();
    Err(Issue::new(
        key,
        format!("`{leaf}` does not apply to a {shape}"),
        format!("a {shape} takes {takes}; remove `{leaf}` or change `shape`"),
    ))
}

fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

/// Normalise a direction, leaving the zero vector (an error the checks report).
fn unit_or_zero(v: [f32; 3]) -> Vec3 {
    model::unit_or_zero(vec3(v))
}

/// A contact table over [`Contact::default`].
fn contact(raw: Option<RawContact>) -> Contact {
    let defaults = Contact::default();
    let Some(raw) = raw else {
        return defaults;
    };
    Contact {
        mode: match raw.mode {
            Some(RawMode::Sticky) => ContactMode::Sticky,
            Some(RawMode::Slip) => ContactMode::Slip,
            Some(RawMode::Separate) => ContactMode::Separate,
            None => defaults.mode,
        },
        friction: raw.friction.unwrap_or(defaults.friction),
    }
}

/// The default scene name for a file: its stem if it is a `.toml` file,
/// else [`Scene::DEFAULT_NAME`].
fn default_name(origin: &str) -> String {
    let path = Path::new(origin);
    let is_toml = path.extension().is_some_and(|ext| ext == "toml");
    match path.file_stem().and_then(|stem| stem.to_str()) {
        Some(stem) if is_toml && !stem.is_empty() => stem.to_string(),
        _ => Scene::DEFAULT_NAME.to_string(),
    }
}

pub use super::mesh::MAX_SDF_SAMPLES;

/// The mesh file, scale, rotation and centre of a mesh body or collider,
/// checked before the file is read. A relative `mesh` path is taken from the
/// scene file's folder, like an `include` in other tools.
fn mesh_placement(
    path: &KeyPath,
    file: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    center: Vec3,
    origin: &str,
) -> Result<MeshPlacement, Issue> {
    let file = require(file, path.key("mesh"), "the mesh file (OBJ, STL or PLY)")?;
    let scale = match scale.unwrap_or(RawScale::Uniform(1.0)) {
        RawScale::Uniform(factor) => Vec3::splat(factor),
        RawScale::PerAxis(factors) => vec3(factors),
    };
    let folder = Path::new(origin).parent().unwrap_or(Path::new(""));
    let joined = folder.join(&file);
    let placement = MeshPlacement {
        file: std::fs::canonicalize(&joined)
            .or_else(|_| std::path::absolute(&joined))
            .unwrap_or(joined),
        scale,
        rotation_degrees: vec3(rotation.unwrap_or([0.0; 3])),
        center,
    };
    check_mesh_placement(path, &placement)?;
    Ok(placement)
}

/// Scale factors greater than 0; finite rotation and centre.
fn check_mesh_placement(path: &KeyPath, placement: &MeshPlacement) -> Check {
    for factor in placement.scale.to_array() {
        positive(
            factor,
            path.key("scale"),
            "scale by a factor greater than 0, e.g. scale = 2.0 or scale = [1.0, 2.0, 1.0]"
                .to_string(),
        )?;
    }
    finite_vec(placement.rotation_degrees, path.key("rotation"))?;
    finite_vec(placement.center, path.key("center"))
}

/// A mesh that cannot be read, located at the `mesh` key that names it.
fn mesh_issue(path: &KeyPath, err: &firn_mesh::MeshError) -> Issue {
    let location = match err.line {
        Some(line) => format!("{}:{line}", err.path.display()),
        None => err.path.display().to_string(),
    };
    Issue::new(
        path.key("mesh"),
        format!("{path}.mesh cannot be used: {location}: {}", err.message),
        err.hint.clone(),
    )
}

/// The signed distance sample spacing: positive, and not so fine that the
/// field would not fit.
fn check_sdf_spacing(path: &KeyPath, spacing: f32) -> Check {
    positive(
        spacing,
        path.key("sdf_spacing"),
        "set the signed distance sample spacing in metres, e.g. sdf_spacing = 0.01, or remove \
         it to use half the domain's cell size"
            .to_string(),
    )
}

/// The field of a placed mesh collider must stay under [`MAX_SDF_SAMPLES`].
fn check_sdf_size(path: &KeyPath, (low, high): (Vec3, Vec3), spacing: f32) -> Check {
    let samples = MeshCollider::sdf_samples((low, high), spacing);
    ensure(
        samples <= MAX_SDF_SAMPLES,
        path.key("sdf_spacing"),
        &format!("coarse enough for at most {MAX_SDF_SAMPLES} signed distance samples"),
        format!("{samples} samples"),
        "raise sdf_spacing, or scale the mesh down".to_string(),
    )
}

fn body_shape_name(shape: RawBodyShape) -> &'static str {
    match shape {
        RawBodyShape::Sphere => "sphere",
        RawBodyShape::Box => "box",
        RawBodyShape::Cylinder => "cylinder",
        RawBodyShape::Mesh => "mesh",
    }
}

fn collider_shape_name(shape: RawColliderShape) -> &'static str {
    match shape {
        RawColliderShape::Plane => "plane",
        RawColliderShape::Sphere => "sphere",
        RawColliderShape::Box => "box",
        RawColliderShape::Mesh => "mesh",
    }
}

fn resolve(raw: RawScene, origin: &str) -> Result<Scene, Issue> {
    // `format` was checked on the spanned tree already.
    let _ = raw.format;
    if flow::is_flow_scene(&raw)? {
        return flow::resolve_flow_scene(raw, origin);
    }
    let name = raw.name.unwrap_or_else(|| default_name(origin));

    let domain_path = KeyPath::of("domain");
    let raw_domain = raw.domain.ok_or_else(|| {
        Issue::new(
            domain_path.clone(),
            "the scene has no [domain] table",
            "add a [domain] table with max and cell_size, e.g. [domain] max = [2.0, 2.0, 2.0] \
             cell_size = 0.02",
        )
    })?;
    let domain = Domain {
        walls: contact(raw_domain.walls),
        ..Domain::new(
            raw_domain.min.map_or(Vec3::ZERO, vec3),
            vec3(require(
                raw_domain.max,
                domain_path.key("max"),
                "the upper corner",
            )?),
            require(
                raw_domain.cell_size,
                domain_path.key("cell_size"),
                "the grid spacing in metres",
            )?,
        )
    };

    let time = resolve_time(raw.time)?;
    let solver = resolve_solver(raw.solver)?;
    let declared = resolve_materials(raw.materials.unwrap_or_default())?;

    let mut materials: Vec<Material> = Vec::new();
    let mut bodies = Vec::new();
    for (index, raw_body) in raw.bodies.unwrap_or_default().into_iter().enumerate() {
        let path = KeyPath::of("bodies").index(index);
        let material_name = raw_body
            .material
            .clone()
            .unwrap_or_else(|| Material::DEFAULT_PRESET.to_string());
        let material = match materials.iter().position(|m| m.name == material_name) {
            Some(found) => found,
            None => {
                let material = declared
                    .get(&material_name)
                    .cloned()
                    .or_else(|| Material::preset(&material_name))
                    .ok_or_else(|| unknown_material(&path, &material_name, &declared))?;
                materials.push(material);
                materials.len() - 1
            }
        };
        bodies.push(resolve_body(&path, raw_body, material, origin)?);
    }

    let mut colliders = Vec::new();
    for (index, raw_collider) in raw.colliders.unwrap_or_default().into_iter().enumerate() {
        let path = KeyPath::of("colliders").index(index);
        colliders.push(resolve_collider(&path, raw_collider, origin, &domain)?);
    }

    let wind = flow::resolve_wind(raw.wind, &domain)?;
    let output = resolve_output(raw.output, &name, &SceneKind::Snow);
    let camera = resolve_camera(raw.camera)?;
    let render = resolve_render(raw.render);
    Ok(Scene {
        name,
        domain,
        time,
        solver,
        materials,
        bodies,
        colliders,
        output,
        camera,
        render,
        kind: SceneKind::Snow,
        compute: resolve_compute(raw.compute),
        wind,
    })
}

/// The `[compute]` table with its default (`backend = "auto"`).
fn resolve_compute(raw: Option<RawCompute>) -> ComputeSettings {
    ComputeSettings {
        backend: raw.and_then(|raw| raw.backend).unwrap_or_default(),
    }
}

fn resolve_time(raw: Option<RawTime>) -> Result<TimeSettings, Issue> {
    let path = KeyPath::of("time");
    let raw = raw.ok_or_else(|| {
        Issue::new(
            path.clone(),
            "the scene has no [time] table",
            "add a [time] table with the simulated duration, e.g. [time] duration = 2.0",
        )
    })?;
    let duration = require(
        raw.duration,
        path.key("duration"),
        "the simulated time in seconds",
    )?;
    let fps = raw.fps.unwrap_or(TimeSettings::DEFAULT_FPS);
    let step = match raw.step.unwrap_or(RawStep::Adaptive) {
        RawStep::Fixed => {
            if raw.cfl.is_some() {
                return Err(Issue::new(
                    path.key("cfl"),
                    "time.cfl only applies when step = \"adaptive\"",
                    "remove cfl, or set step = \"adaptive\"",
                ));
            }
            let dt = raw.dt.ok_or_else(|| {
                Issue::new(
                    path.key("dt"),
                    "time.step is \"fixed\" but time.dt is missing",
                    "add the step length in seconds, e.g. dt = 0.001, or use step = \"adaptive\"",
                )
                .pointing_at(path.key("step"))
            })?;
            TimeStep::Fixed { dt }
        }
        RawStep::Adaptive => TimeStep::Adaptive {
            cfl: raw.cfl.unwrap_or(TimeStep::DEFAULT_CFL),
            // The default bound never exceeds one frame.
            max_dt: raw.dt.unwrap_or_else(|| TimeStep::default_max_dt(fps)),
        },
    };
    Ok(TimeSettings {
        duration,
        fps,
        step,
        max_substeps_per_frame: raw
            .max_substeps_per_frame
            .unwrap_or(TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME),
    })
}

fn resolve_solver(raw: Option<RawSolver>) -> Result<SolverSettings, Issue> {
    let raw = raw.unwrap_or(RawSolver {
        transfer: None,
        flip: None,
        gravity: None,
        seed: None,
        integrator: None,
        implicit_beta: None,
        solver_tolerance: None,
        solver_max_iterations: None,
    });
    let integrator = resolve_integrator(&raw)?;
    let defaults = SolverSettings::default();
    Ok(SolverSettings {
        transfer: match raw.transfer {
            Some(RawTransfer::Apic) => Transfer::Apic,
            Some(RawTransfer::PicFlip) => Transfer::PicFlip,
            None => defaults.transfer,
        },
        flip_blend: raw.flip.unwrap_or(defaults.flip_blend),
        gravity: raw.gravity.map_or(defaults.gravity, vec3),
        seed: raw.seed.unwrap_or(defaults.seed),
        integrator,
    })
}

/// The time integrator; the semi-implicit solver's keys are an error with
/// the explicit one, like `cfl` with a fixed step.
fn resolve_integrator(raw: &RawSolver) -> Result<Integrator, Issue> {
    // Without the key: the kind of `Integrator::default()`.
    let integrator = raw.integrator.unwrap_or(match Integrator::default() {
        Integrator::Explicit => RawIntegrator::Explicit,
        Integrator::SemiImplicit(_) => RawIntegrator::SemiImplicit,
    });
    match integrator {
        RawIntegrator::SemiImplicit => {
            let defaults = ImplicitSettings::default();
            Ok(Integrator::SemiImplicit(ImplicitSettings {
                beta: raw.implicit_beta.unwrap_or(defaults.beta),
                tolerance: raw.solver_tolerance.unwrap_or(defaults.tolerance),
                max_iterations: raw.solver_max_iterations.unwrap_or(defaults.max_iterations),
            }))
        }
        RawIntegrator::Explicit => {
            let implicit_keys = [
                ("implicit_beta", raw.implicit_beta.is_some()),
                ("solver_tolerance", raw.solver_tolerance.is_some()),
                ("solver_max_iterations", raw.solver_max_iterations.is_some()),
            ];
            match implicit_keys.iter().find(|(_, given)| *given) {
                Some((key, _)) => Err(Issue::new(
                    KeyPath::of("solver").key(key),
                    format!("solver.{key} only applies when integrator = \"semi-implicit\""),
                    format!("remove {key}, or set integrator = \"semi-implicit\""),
                )),
                None => Ok(Integrator::Explicit),
            }
        }
    }
}

/// Expand every `[materials.NAME]` table over its preset and check it, used
/// or not.
fn resolve_materials(
    raw: BTreeMap<String, RawMaterial>,
) -> Result<BTreeMap<String, Material>, Issue> {
    let mut declared = BTreeMap::new();
    for (name, raw_material) in raw {
        let path = KeyPath::of("materials").key(&name);
        // The base: the named preset, else the preset this table overrides,
        // else snow.
        let base_name = match &raw_material.preset {
            Some(preset) => preset.clone(),
            None if PRESET_NAMES.contains(&name.as_str()) => name.clone(),
            None => Material::DEFAULT_PRESET.to_string(),
        };
        let base = Material::preset(&base_name).ok_or_else(|| {
            let mut hint = String::new();
            if let Some(best) = closest(&base_name, &PRESET_NAMES) {
                hint.push_str(&format!("did you mean \"{best}\"? "));
            }
            hint.push_str(&format!("the presets are {}", PRESET_NAMES.join(", ")));
            Issue::new(
                path.key("preset"),
                format!("{path}.preset names no preset \"{base_name}\""),
                hint,
            )
        })?;
        let material = Material {
            name: name.clone(),
            youngs_modulus: raw_material.youngs_modulus.unwrap_or(base.youngs_modulus),
            poisson_ratio: raw_material.poisson_ratio.unwrap_or(base.poisson_ratio),
            hardening: raw_material.hardening.unwrap_or(base.hardening),
            critical_compression: raw_material
                .critical_compression
                .unwrap_or(base.critical_compression),
            critical_stretch: raw_material
                .critical_stretch
                .unwrap_or(base.critical_stretch),
            density: raw_material.density.unwrap_or(base.density),
        };
        check_material(&path, &material)?;
        declared.insert(name, material);
    }
    Ok(declared)
}

fn unknown_material(body: &KeyPath, name: &str, declared: &BTreeMap<String, Material>) -> Issue {
    let mut known: Vec<&str> = PRESET_NAMES.to_vec();
    for declared_name in declared.keys() {
        if !known.contains(&declared_name.as_str()) {
            known.push(declared_name);
        }
    }
    let mut hint = String::new();
    if let Some(best) = closest(name, &known) {
        hint.push_str(&format!("did you mean \"{best}\"? "));
    }
    hint.push_str(&format!(
        "known materials: {}; or define it in a [materials.{}] table",
        known.join(", "),
        KeyPath::of(name)
    ));
    Issue::new(
        body.key("material"),
        format!("{body}.material names an unknown material \"{name}\""),
        hint,
    )
}

fn resolve_body(
    path: &KeyPath,
    raw: RawBody,
    material: usize,
    origin: &str,
) -> Result<Body, Issue> {
    let shape_kind = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the shape to fill").with_hint(
            "add shape = \"sphere\", \"box\", \"cylinder\" or \"mesh\" with its dimensions",
        )
    })?;
    let center = vec3(require(raw.center, path.key("center"), "the centre")?);
    if !matches!(shape_kind, RawBodyShape::Mesh) {
        let shape = body_shape_name(shape_kind);
        let takes = "mesh, scale, rotation and center";
        reject(&raw.mesh, path.key("mesh"), shape, takes)?;
        reject(&raw.scale, path.key("scale"), shape, takes)?;
        reject(&raw.rotation, path.key("rotation"), shape, takes)?;
    }
    let shape = match shape_kind {
        RawBodyShape::Mesh => {
            let takes = "mesh, scale, rotation and center";
            reject(&raw.radius, path.key("radius"), "mesh", takes)?;
            reject(&raw.size, path.key("size"), "mesh", takes)?;
            reject(&raw.height, path.key("height"), "mesh", takes)?;
            reject(&raw.axis, path.key("axis"), "mesh", takes)?;
            let placement =
                mesh_placement(path, raw.mesh, raw.scale, raw.rotation, center, origin)?;
            let body = MeshBody::load(placement).map_err(|err| mesh_issue(path, &err))?;
            Shape::Mesh(Box::new(body))
        }
        RawBodyShape::Sphere => {
            let takes = "center and radius";
            reject(&raw.size, path.key("size"), "sphere", takes)?;
            reject(&raw.height, path.key("height"), "sphere", takes)?;
            reject(&raw.axis, path.key("axis"), "sphere", takes)?;
            Shape::Sphere {
                center,
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
            }
        }
        RawBodyShape::Box => {
            let takes = "center and size";
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            reject(&raw.height, path.key("height"), "box", takes)?;
            reject(&raw.axis, path.key("axis"), "box", takes)?;
            Shape::Box {
                center,
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
        RawBodyShape::Cylinder => {
            reject(
                &raw.size,
                path.key("size"),
                "cylinder",
                "center, radius, height and axis",
            )?;
            Shape::Cylinder {
                center,
                axis: unit_or_zero(raw.axis.unwrap_or([0.0, 1.0, 0.0])),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
                height: require(raw.height, path.key("height"), "the length along the axis")?,
            }
        }
    };
    let mut body = Body::new(shape).material(material);
    if let Some(velocity) = raw.velocity {
        body.velocity = vec3(velocity);
    }
    if let Some(count) = raw.particles_per_cell {
        body.particles_per_cell = count;
    }
    if let Some(clumps) = raw.clumps {
        body.clumps = Some(Clumps {
            size: clumps.size.ok_or_else(|| {
                missing(path.key("clumps").key("size"), "the clump size in metres")
                    .with_hint("add the clump diameter, e.g. clumps = { size = 0.05 }")
            })?,
            contrast: clumps.contrast.unwrap_or(DEFAULT_CLUMP_CONTRAST),
        });
    }
    Ok(body)
}

fn resolve_collider(
    path: &KeyPath,
    raw: RawCollider,
    origin: &str,
    domain: &Domain,
) -> Result<Collider, Issue> {
    let shape = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the collider's shape")
            .with_hint("add shape = \"plane\", \"sphere\", \"box\" or \"mesh\" with its dimensions")
    })?;
    if !matches!(shape, RawColliderShape::Mesh) {
        let name = collider_shape_name(shape);
        let takes = "mesh, scale, rotation, center and sdf_spacing";
        reject(&raw.mesh, path.key("mesh"), name, takes)?;
        reject(&raw.scale, path.key("scale"), name, takes)?;
        reject(&raw.rotation, path.key("rotation"), name, takes)?;
        reject(&raw.sdf_spacing, path.key("sdf_spacing"), name, takes)?;
    }
    let geometry = match shape {
        RawColliderShape::Mesh => {
            let takes = "mesh, scale, rotation, center and sdf_spacing";
            reject(&raw.point, path.key("point"), "mesh", takes)?;
            reject(&raw.normal, path.key("normal"), "mesh", takes)?;
            reject(&raw.radius, path.key("radius"), "mesh", takes)?;
            reject(&raw.size, path.key("size"), "mesh", takes)?;
            let center = vec3(require(raw.center, path.key("center"), "the centre")?);
            let placement =
                mesh_placement(path, raw.mesh, raw.scale, raw.rotation, center, origin)?;
            let spacing = raw.sdf_spacing.unwrap_or(0.5 * domain.cell_size);
            check_sdf_spacing(path, spacing)?;
            let placed = placement.load().map_err(|err| mesh_issue(path, &err))?;
            check_sdf_size(path, placed.mesh.bounds(), spacing)?;
            ColliderGeometry::Mesh(Box::new(MeshCollider::from_placed(
                placement, placed, spacing,
            )))
        }
        RawColliderShape::Plane => {
            let takes = "point and normal";
            reject(&raw.center, path.key("center"), "plane", takes)?;
            reject(&raw.radius, path.key("radius"), "plane", takes)?;
            reject(&raw.size, path.key("size"), "plane", takes)?;
            ColliderGeometry::HalfPlane {
                point: vec3(require(
                    raw.point,
                    path.key("point"),
                    "a point on the plane",
                )?),
                normal: unit_or_zero(require(
                    raw.normal,
                    path.key("normal"),
                    "the normal pointing into the free side",
                )?),
            }
        }
        RawColliderShape::Sphere => {
            let takes = "center and radius";
            reject(&raw.point, path.key("point"), "sphere", takes)?;
            reject(&raw.normal, path.key("normal"), "sphere", takes)?;
            reject(&raw.size, path.key("size"), "sphere", takes)?;
            ColliderGeometry::Sphere {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
            }
        }
        RawColliderShape::Box => {
            let takes = "center and size";
            reject(&raw.point, path.key("point"), "box", takes)?;
            reject(&raw.normal, path.key("normal"), "box", takes)?;
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            ColliderGeometry::Box {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
    };
    let motion = match (raw.velocity, raw.keyframes) {
        (Some(_), Some(_)) => {
            return Err(Issue::new(
                path.key("keyframes"),
                format!("{path} has both velocity and keyframes"),
                "a collider moves either with a constant velocity or through keyframes; \
                 remove one of the two",
            ));
        }
        (Some(velocity), None) => Motion::Linear {
            velocity: vec3(velocity),
        },
        (None, Some(raw_keys)) => {
            let mut keys = Vec::with_capacity(raw_keys.len());
            for (index, key) in raw_keys.into_iter().enumerate() {
                let key_path = path.key("keyframes").index(index);
                keys.push(Keyframe {
                    time: require(key.time, key_path.key("time"), "the key's time in seconds")?,
                    position: vec3(require(
                        key.position,
                        key_path.key("position"),
                        "where the collider's reference point is at that time",
                    )?),
                });
            }
            Motion::Keyframed { keys }
        }
        (None, None) => Motion::Static,
    };
    Ok(Collider {
        motion,
        contact: contact(Some(RawContact {
            mode: raw.mode,
            friction: raw.friction,
        })),
        ..Collider::new(geometry)
    })
}

/// The `[output]` table over [`OutputSettings::for_scene`]; the attributes
/// default to those of `kind`.
fn resolve_output(raw: Option<RawOutput>, name: &str, kind: &SceneKind) -> OutputSettings {
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

fn resolve_camera(raw: Option<RawCamera>) -> Result<Camera, Issue> {
    let Some(raw) = raw else {
        return Ok(Camera::default());
    };
    let defaults = Camera::default();
    let mut path = Vec::new();
    for (index, key) in raw.path.unwrap_or_default().into_iter().enumerate() {
        let at = KeyPath::of("camera").key("path").index(index);
        path.push(CameraKey {
            time: require(key.time, at.key("time"), "the simulated time of this view")?,
            position: vec3(require(
                key.position,
                at.key("position"),
                "the eye position",
            )?),
            look_at: vec3(require(
                key.look_at,
                at.key("look_at"),
                "the point looked at",
            )?),
        });
    }
    Ok(Camera {
        position: raw.position.map(vec3),
        look_at: raw.look_at.map(vec3),
        fov_degrees: raw.fov.unwrap_or(defaults.fov_degrees),
        orbit: raw
            .orbit
            .map(|degrees_per_second| Orbit { degrees_per_second }),
        path,
    })
}

fn resolve_render(raw: Option<RawRender>) -> RenderSettings {
    let defaults = RenderSettings::default();
    let Some(raw) = raw else {
        return defaults;
    };
    RenderSettings {
        enabled: raw.enabled.unwrap_or(defaults.enabled),
        styles: raw.styles.unwrap_or(defaults.styles),
        size: raw.size.unwrap_or(defaults.size),
        color_by: raw.color_by.unwrap_or(defaults.color_by),
        legend: raw.legend.unwrap_or(defaults.legend),
        point_radius: raw.point_radius,
        trail_length: raw.trail_length.unwrap_or(defaults.trail_length),
        smooth_trails: raw.smooth_trails.unwrap_or(defaults.smooth_trails),
    }
}

// ---------------------------------------------------------------------------
// Checks on the model
// ---------------------------------------------------------------------------

/// The rules every scene must satisfy, in document order. Key paths use the
/// names of the file format.
fn check_scene(scene: &Scene) -> Check {
    if scene.name.trim().is_empty() {
        return Err(Issue::new(
            KeyPath::of("name"),
            "name must not be empty",
            "name the scene, e.g. name = \"snowball\", or remove the key to use the file name",
        ));
    }
    if let SceneKind::Flow(settings) = &scene.kind {
        return flow::check_flow_scene(scene, settings);
    }
    check_domain(&scene.domain)?;
    check_time(&scene.time)?;
    check_solver(&scene.solver)?;
    for material in &scene.materials {
        check_material(&KeyPath::of("materials").key(&material.name), material)?;
    }
    if scene.bodies.is_empty() {
        return Err(Issue::new(
            KeyPath::of("bodies"),
            "the scene has no snow: there is no [[bodies]] table",
            "add a [[bodies]] table, e.g. [[bodies]] shape = \"sphere\" center = [1.0, 0.5, 1.0] \
             radius = 0.1",
        ));
    }
    let mut lattice_points = 0u64;
    for (index, body) in scene.bodies.iter().enumerate() {
        check_body(scene, index, body)?;
        lattice_points =
            lattice_points.saturating_add(sampling::lattice_points(body, scene.domain.cell_size));
        check_lattice_points(scene, index, lattice_points)?;
        check_body_has_particles(scene, index, body)?;
    }
    check_first_step(scene)?;
    if let Some(wind) = &scene.wind {
        flow::check_wind(wind)?;
    }
    for (index, collider) in scene.colliders.iter().enumerate() {
        check_collider(&KeyPath::of("colliders").index(index), collider)?;
    }
    check_output(&scene.output)?;
    check_vdb(&scene.output.vdb, scene.domain.cell_size)?;
    check_mesh(&scene.output.mesh, scene.domain.cell_size)?;
    check_camera(&scene.camera)?;
    check_render(&scene.render)
}

/// `value` must satisfy `ok`; else "`path` must be `rule` (got value)".
fn ensure(ok: bool, path: KeyPath, rule: &str, got: impl fmt::Display, hint: String) -> Check {
    if ok {
        Ok(())
    } else {
        let message = format!("{path} must be {rule} (got {got})");
        Err(Issue::new(path, message, hint))
    }
}

fn positive(value: f32, path: KeyPath, hint: String) -> Check {
    let rule = if value.is_finite() {
        "greater than 0"
    } else {
        "a finite number greater than 0"
    };
    ensure(
        value > 0.0 && value.is_finite(),
        path,
        rule,
        Num::from(value),
        hint,
    )
}

fn not_negative(value: f32, path: KeyPath, hint: String) -> Check {
    let rule = if value.is_finite() {
        "0 or more"
    } else {
        "a finite number, 0 or more"
    };
    ensure(
        value >= 0.0 && value.is_finite(),
        path,
        rule,
        Num::from(value),
        hint,
    )
}

fn finite_vec(value: Vec3, path: KeyPath) -> Check {
    let leaf = path.leaf().unwrap_or("").to_string();
    let hint = match example(&leaf) {
        Some(example) => format!("use finite numbers, e.g. {example}"),
        None => "use finite numbers".to_string(),
    };
    ensure(value.is_finite(), path, "finite", format_vec(value), hint)
}

fn positive_vec(value: Vec3, path: KeyPath, hint: String) -> Check {
    ensure(
        value.cmpgt(Vec3::ZERO).all() && value.is_finite(),
        path,
        "greater than 0 on every axis",
        format_vec(value),
        hint,
    )
}

/// A direction must be a non-zero unit vector.
fn unit_vec(value: Vec3, path: KeyPath) -> Check {
    finite_vec(value, path.clone())?;
    let leaf = path.leaf().unwrap_or("").to_string();
    let hint = format!(
        "give a direction, e.g. {}",
        example(&leaf).unwrap_or("[0.0, 1.0, 0.0]")
    );
    if value.length_squared() == 0.0 {
        return Err(Issue::new(
            path.clone(),
            format!("{path} must not be the zero vector"),
            hint,
        ));
    }
    let length = value.length();
    ensure(
        (length - 1.0).abs() <= 1e-3,
        path,
        "a unit vector",
        format!("length {length}"),
        "divide the vector by its length (scene files are normalised when loaded)".to_string(),
    )
}

fn format_vec(v: Vec3) -> String {
    format!(
        "[{}, {}, {}]",
        Num::from(v.x),
        Num::from(v.y),
        Num::from(v.z)
    )
}

/// A number for messages: at most six significant digits, so that an `f32`
/// such as 1.9 - 0.2 reads 1.7 rather than 1.6999999.
#[derive(Clone, Copy, Debug)]
struct Num(f64);

impl From<f32> for Num {
    fn from(value: f32) -> Num {
        Num(f64::from(value))
    }
}

impl From<f64> for Num {
    fn from(value: f64) -> Num {
        Num(value)
    }
}

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.0.is_finite() || self.0 == 0.0 {
            return write!(f, "{}", self.0);
        }
        let rounded: f64 = format!("{:.5e}", self.0).parse().unwrap_or(self.0);
        if rounded.abs() >= 1e-4 && rounded.abs() < 1e7 {
            write!(f, "{rounded}")
        } else {
            write!(f, "{rounded:e}")
        }
    }
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn check_contact(path: &KeyPath, contact: &Contact) -> Check {
    not_negative(
        contact.friction,
        path.key("friction"),
        "set the Coulomb friction coefficient, e.g. friction = 0.2 (0: frictionless)".to_string(),
    )
}

fn check_domain(domain: &Domain) -> Check {
    let path = KeyPath::of("domain");
    finite_vec(domain.min, path.key("min"))?;
    finite_vec(domain.max, path.key("max"))?;
    for (axis, name) in AXES.iter().enumerate() {
        if domain.max[axis] <= domain.min[axis] {
            return Err(Issue::new(
                path.key("max"),
                format!(
                    "domain.max must be greater than domain.min on every axis, but along {name} \
                     max = {} and min = {}",
                    Num::from(domain.max[axis]),
                    Num::from(domain.min[axis])
                ),
                "give the upper corner of the box, e.g. min = [0.0, 0.0, 0.0] and \
                 max = [2.0, 2.0, 2.0]",
            ));
        }
    }
    positive(
        domain.cell_size,
        path.key("cell_size"),
        "set cell_size to the grid spacing in metres, e.g. cell_size = 0.02".to_string(),
    )?;
    let extent = (domain.max - domain.min).as_dvec3();
    let h = f64::from(domain.cell_size);
    let cells = [extent.x, extent.y, extent.z].map(|e| (e / h - 1e-4).ceil().max(1.0));
    for (axis, name) in AXES.iter().enumerate() {
        if cells[axis] > MAX_CELLS_PER_AXIS as f64 {
            let smallest = round_up_3_digits(extent[axis] / MAX_CELLS_PER_AXIS as f64);
            return Err(Issue::new(
                path.key("cell_size"),
                format!(
                    "the grid would have {} cells along {name} (the limit is \
                     {MAX_CELLS_PER_AXIS})",
                    cells[axis]
                ),
                format!(
                    "use a larger cell_size (at least {smallest} for this domain) or a \
                     smaller domain"
                ),
            ));
        }
    }
    let total = cells[0] * cells[1] * cells[2];
    if total > MAX_CELLS as f64 {
        return Err(Issue::new(
            path.key("cell_size"),
            format!(
                "the grid would have {total} cells ({} x {} x {}; the limit is 2^30 = {MAX_CELLS})",
                cells[0], cells[1], cells[2]
            ),
            "use a larger cell_size or a smaller domain",
        ));
    }
    check_contact(&path.key("walls"), &domain.walls)
}

fn check_time(time: &TimeSettings) -> Check {
    let path = KeyPath::of("time");
    let duration_ok = time.duration > 0.0 && time.duration.is_finite();
    ensure(
        duration_ok,
        path.key("duration"),
        "greater than 0",
        Num(time.duration),
        "set the simulated time in seconds, e.g. duration = 2.0".to_string(),
    )?;
    ensure(
        time.fps > 0.0 && time.fps.is_finite(),
        path.key("fps"),
        "greater than 0",
        Num(time.fps),
        "set the output frames per simulated second, e.g. fps = 30".to_string(),
    )?;
    check_frame_count(time)?;
    ensure(
        time.max_substeps_per_frame >= 1,
        path.key("max_substeps_per_frame"),
        "at least 1",
        time.max_substeps_per_frame,
        format!(
            "allow the frames some substeps, e.g. max_substeps_per_frame = {}",
            TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME
        ),
    )?;
    let frame = 1.0 / time.fps;
    let (dt, what) = match time.step {
        TimeStep::Fixed { dt } => (dt, "the fixed step"),
        TimeStep::Adaptive { cfl, max_dt } => {
            ensure(
                cfl > 0.0 && cfl <= 1.0,
                path.key("cfl"),
                "in (0, 1]",
                Num::from(cfl),
                "set the CFL number, the fraction of a cell crossed per step, e.g. cfl = 0.4"
                    .to_string(),
            )?;
            (max_dt, "the largest adaptive step")
        }
    };
    positive(
        dt,
        path.key("dt"),
        format!("set {what} in seconds, e.g. dt = 0.001"),
    )?;
    if f64::from(dt) > frame * (1.0 + 1e-6) {
        return Err(Issue::new(
            path.key("dt"),
            format!(
                "time.dt must not exceed one frame (1/fps = {}), but it is {}; {what} would \
                 skip frames",
                Num(frame),
                Num::from(dt)
            ),
            format!("use dt = {} or less, or lower fps", Num(frame.min(1e-3))),
        ));
    }
    Ok(())
}

/// The duration and frame rate must make at most [`MAX_FRAMES`] frames.
fn check_frame_count(time: &TimeSettings) -> Check {
    let frames = (time.duration * time.fps - 1e-9).ceil();
    if frames <= f64::from(MAX_FRAMES) {
        return Ok(());
    }
    Err(Issue::new(
        KeyPath::of("time").key("duration"),
        format!(
            "time.duration = {} s at {} fps makes {} frames; the limit is {MAX_FRAMES} (frame \
             numbers keep five digits in file names)",
            Num(time.duration),
            Num(time.fps),
            Num(frames)
        ),
        format!(
            "simulate at most {} s at this frame rate, or lower fps",
            Num(f64::from(MAX_FRAMES) / time.fps)
        ),
    ))
}

fn check_solver(solver: &SolverSettings) -> Check {
    let path = KeyPath::of("solver");
    ensure(
        (0.0..=1.0).contains(&solver.flip_blend),
        path.key("flip"),
        "in [0, 1]",
        Num::from(solver.flip_blend),
        "set the FLIP share of the PIC/FLIP blend, e.g. flip = 0.95 (0: pure PIC)".to_string(),
    )?;
    finite_vec(solver.gravity, path.key("gravity"))?;
    check_integrator(&path, &solver.integrator)
}

fn check_integrator(path: &KeyPath, integrator: &Integrator) -> Check {
    let Integrator::SemiImplicit(settings) = integrator else {
        return Ok(());
    };
    ensure(
        (0.0..=1.0).contains(&settings.beta),
        path.key("implicit_beta"),
        "in [0, 1]",
        Num::from(settings.beta),
        "set how implicit the update is, e.g. implicit_beta = 0.5 (0: explicit, 1: backward \
         Euler)"
            .to_string(),
    )?;
    ensure(
        settings.tolerance > 0.0 && settings.tolerance < 1.0,
        path.key("solver_tolerance"),
        "in (0, 1)",
        Num::from(settings.tolerance),
        "set the relative residual at which the solve stops, e.g. solver_tolerance = 1e-3 \
         (below 1e-5, f32 rounding may keep it from converging)"
            .to_string(),
    )?;
    ensure(
        settings.max_iterations >= 1,
        path.key("solver_max_iterations"),
        "at least 1",
        settings.max_iterations,
        "allow the solver some iterations, e.g. solver_max_iterations = 100".to_string(),
    )
}

/// The constitutive parameter ranges (Stomakhin et al. 2013).
fn check_material(path: &KeyPath, material: &Material) -> Check {
    positive(
        material.youngs_modulus,
        path.key("youngs_modulus"),
        "set Young's modulus E in pascals, e.g. youngs_modulus = 1.4e5".to_string(),
    )?;
    let nu = material.poisson_ratio;
    if nu <= -1.0 || !nu.is_finite() {
        return Err(Issue::new(
            path.key("poisson_ratio"),
            format!(
                "{path}.poisson_ratio must be greater than -1 (got {}): the shear modulus \
                 μ = E/(2(1+ν)) would not be positive",
                Num::from(nu)
            ),
            "use a value like 0.3 (snow: 0.2)",
        ));
    }
    if nu >= 0.5 {
        return Err(Issue::new(
            path.key("poisson_ratio"),
            format!(
                "{path}.poisson_ratio must be less than 0.5 (got {}): the Lamé parameter \
                 λ = Eν/((1+ν)(1-2ν)) becomes infinite at 0.5 and negative above it",
                Num::from(nu)
            ),
            "use a value like 0.3 (snow: 0.2)",
        ));
    }
    not_negative(
        material.hardening,
        path.key("hardening"),
        "set the hardening coefficient ξ, e.g. hardening = 10.0 (0: no hardening)".to_string(),
    )?;
    ensure(
        (0.0..1.0).contains(&material.critical_compression),
        path.key("critical_compression"),
        "in [0, 1)",
        Num::from(material.critical_compression),
        "set θc, how far snow compresses before it yields, e.g. critical_compression = 0.025"
            .to_string(),
    )?;
    not_negative(
        material.critical_stretch,
        path.key("critical_stretch"),
        "set θs, how far snow stretches before it yields, e.g. critical_stretch = 0.0075"
            .to_string(),
    )?;
    positive(
        material.density,
        path.key("density"),
        "set the initial density ρ0 in kg/m³, e.g. density = 400.0".to_string(),
    )
}

/// The box `low .. high` of the thing at `path` (a `what`) must lie inside
/// the domain; the error names the axis and both spans.
fn check_inside_domain(
    path: &KeyPath,
    what: &str,
    (low, high): (Vec3, Vec3),
    domain: &Domain,
    hint: &str,
) -> Check {
    let slack = 1e-6 * (domain.max - domain.min).max_element();
    for (axis, a) in AXES.iter().enumerate() {
        if low[axis] < domain.min[axis] - slack || high[axis] > domain.max[axis] + slack {
            return Err(Issue::new(
                path.key("center"),
                format!(
                    "{path} ({what}) sticks out of the domain along {a}: it spans {a} = {} .. {} \
                     but the domain spans {a} = {} .. {}",
                    Num::from(low[axis]),
                    Num::from(high[axis]),
                    Num::from(domain.min[axis]),
                    Num::from(domain.max[axis])
                ),
                hint,
            ));
        }
    }
    Ok(())
}

fn shape_name(shape: &Shape) -> &'static str {
    match shape {
        Shape::Sphere { .. } => "sphere",
        Shape::Box { .. } => "box",
        Shape::Cylinder { .. } => "cylinder",
        Shape::Mesh(_) => "mesh",
    }
}

fn check_body(scene: &Scene, index: usize, body: &Body) -> Check {
    let path = KeyPath::of("bodies").index(index);
    if body.material >= scene.materials.len() {
        return Err(Issue::new(
            path.key("material"),
            format!(
                "{path}.material is material {} but the scene has {} materials",
                body.material,
                scene.materials.len()
            ),
            "use an index into Scene::materials",
        ));
    }
    let ppc = body.particles_per_cell;
    ensure(
        (1..=MAX_PARTICLES_PER_CELL).contains(&ppc),
        path.key("particles_per_cell"),
        "between 1 and 64",
        ppc,
        "use particles_per_cell = 8 (the usual value)".to_string(),
    )?;
    finite_vec(body.velocity, path.key("velocity"))?;
    if let Some(clumps) = body.clumps {
        check_clumps(&path.key("clumps"), clumps, scene.domain.cell_size)?;
    }
    match body.shape {
        Shape::Sphere { center, radius } => {
            check_ball(&path, center, radius)?;
        }
        Shape::Box { center, size } => {
            check_box(&path, center, size)?;
        }
        Shape::Cylinder {
            center,
            axis,
            radius,
            height,
        } => {
            finite_vec(center, path.key("center"))?;
            unit_vec(axis, path.key("axis"))?;
            positive(
                radius,
                path.key("radius"),
                "set the radius in metres, e.g. radius = 0.1".to_string(),
            )?;
            positive(
                height,
                path.key("height"),
                "set the length along the axis in metres, e.g. height = 0.5".to_string(),
            )?;
        }
        Shape::Mesh(ref mesh) => check_mesh_placement(&path, &mesh.placement)?,
    }

    check_inside_domain(
        &path,
        shape_name(&body.shape),
        body.shape.bounds(),
        &scene.domain,
        "move or shrink the body so that it lies inside domain.min .. domain.max, or \
         enlarge the domain",
    )
}

/// Clumps must be resolved by the grid and their contrast bounded.
fn check_clumps(path: &KeyPath, clumps: Clumps, cell_size: f32) -> Check {
    ensure(
        clumps.size.is_finite() && clumps.size >= cell_size,
        path.key("size"),
        "at least domain.cell_size",
        clumps.size,
        format!(
            "clumps smaller than a grid cell are not resolved: use size = {} or more \
             (about 2 to 4 cells looks like hand-packed snow)",
            2.0 * cell_size
        ),
    )?;
    ensure(
        (0.0..=MAX_CONTRAST).contains(&clumps.contrast),
        path.key("contrast"),
        &format!("between 0 and {MAX_CONTRAST}"),
        clumps.contrast,
        format!("use contrast = {DEFAULT_CLUMP_CONTRAST} (the default)"),
    )
}

/// A body must catch at least one particle; its lattice has been checked
/// against [`MAX_LATTICE_POINTS`], so looking is bounded.
fn check_body_has_particles(scene: &Scene, index: usize, body: &Body) -> Check {
    let path = KeyPath::of("bodies").index(index);
    let domain = &scene.domain;
    let ppc = body.particles_per_cell;
    if !sampling::body_has_particles(scene, index) {
        let spacing = sampling::particle_spacing(domain.cell_size, ppc);
        let (cause, hint) = match body.shape {
            Shape::Mesh(_) => (
                "it encloses no volume larger than the particle spacing",
                "check that the mesh is a solid (not a single open sheet) and its scale, raise \
                 particles_per_cell (at most 64), or use a smaller domain.cell_size",
            ),
            _ => (
                "it is too small for the particle spacing",
                "make the body larger, raise particles_per_cell (at most 64), or use a smaller \
                 domain.cell_size",
            ),
        };
        return Err(Issue::new(
            path.clone(),
            format!(
                "{path} ({}) gets no particles: {cause} cell_size / cbrt(particles_per_cell) = \
                 {} m",
                shape_name(&body.shape),
                Num::from(spacing)
            ),
            hint,
        ));
    }
    Ok(())
}

/// The bodies up to `index` must be filled from at most
/// [`MAX_LATTICE_POINTS`] lattice points (`total`), checked before any is
/// visited.
fn check_lattice_points(scene: &Scene, index: usize, total: u64) -> Check {
    if total <= MAX_LATTICE_POINTS {
        return Ok(());
    }
    let body = &scene.bodies[index];
    let path = KeyPath::of("bodies").index(index);
    let h = scene.domain.cell_size;
    let ppc = body.particles_per_cell;
    let estimate = body_estimate(body, h);
    let earlier = total.saturating_sub(estimate.lattice_points);
    let room = MAX_LATTICE_POINTS.saturating_sub(earlier).max(1);
    // The lattice must get this much sparser (points scale with ppc / h³).
    let factor = room as f64 / estimate.lattice_points as f64;
    let coarser_cell = round_up_3_digits(f64::from(h) / factor.cbrt());
    let fewer_per_cell = (f64::from(ppc) * factor).floor() as u32;
    let mut hint = if fewer_per_cell >= 1 {
        format!(
            "lower particles_per_cell to {fewer_per_cell} (now {ppc}), use cell_size = \
             {coarser_cell} or more (now {}), or make the body smaller",
            Num::from(h)
        )
    } else {
        format!(
            "use cell_size = {coarser_cell} or more (now {}), or make the body smaller",
            Num::from(h)
        )
    };
    if estimate.lattice_points / 4 > estimate.particles {
        hint.push_str(
            "; a thin or slanted body is filled through its whole bounding box, so turning it \
             along the axes helps too",
        );
    }
    let before = if earlier > 0 {
        format!(" (with the {earlier} of the bodies before it)")
    } else {
        String::new()
    };
    Err(Issue::new(
        path.key("particles_per_cell"),
        format!(
            "{path} ({}) is filled from {} lattice points, about {} particles needing {} of \
             memory{before}; all bodies together may be filled from at most 2^30 = \
             {MAX_LATTICE_POINTS}",
            shape_name(&body.shape),
            estimate.lattice_points,
            estimate.particles,
            Bytes(estimate.particles.saturating_mul(CPU_BYTES_PER_PARTICLE)),
        ),
        hint,
    ))
}

/// The first substep must leave a frame at most
/// `time.max_substeps_per_frame` substeps; the error names what makes the
/// step short: the fixed or capped step, the fastest body, or the stiffest
/// material.
fn check_first_step(scene: &Scene) -> Check {
    let time = &scene.time;
    let first = scene.first_step();
    let limit = time.max_substeps_per_frame;
    if first.substeps_per_frame <= f64::from(limit) {
        return Ok(());
    }
    let too_many = format!(
        "a frame (1/fps = {} s) would take {} substeps, more than time.max_substeps_per_frame \
         = {limit}",
        Num(1.0 / time.fps),
        Num(first.substeps_per_frame)
    );
    let raise = "or raise [time] max_substeps_per_frame if the frames really need that many \
                 substeps";
    let shortest = Num(time.shortest_dt());
    let dt_path = KeyPath::of("time").key("dt");
    let (cfl, max_dt) = match time.step {
        TimeStep::Fixed { dt } => {
            return Err(Issue::new(
                dt_path,
                format!("time.dt = {} s is too short: {too_many}", Num::from(dt)),
                format!("use dt = {shortest} or more, lower fps, {raise}"),
            ));
        }
        TimeStep::Adaptive { cfl, max_dt } => (cfl, max_dt),
    };
    if first.dt >= max_dt {
        return Err(Issue::new(
            dt_path,
            format!(
                "time.dt = {} s caps the adaptive step so low that {too_many}",
                Num::from(max_dt)
            ),
            format!("use dt = {shortest} or more, lower fps, {raise}"),
        ));
    }
    let h = scene.domain.cell_size;
    let step = format!(
        "the adaptive step starts at Δt = {} s (cfl {} × cell_size {} m / ({} m/s of the \
         fastest body + {} m/s of elastic waves)), so {too_many}",
        Num::from(first.dt),
        Num::from(cfl),
        Num::from(h),
        Num::from(first.speed),
        Num::from(first.wave_speed)
    );
    // Speeds at which a frame takes `limit` substeps, all told.
    let speed_budget = f64::from(cfl) * f64::from(h) / time.shortest_dt();
    if first.speed >= first.wave_speed {
        let (index, body) = scene
            .bodies
            .iter()
            .enumerate()
            .max_by(|a, b| {
                a.1.velocity
                    .length_squared()
                    .total_cmp(&b.1.velocity.length_squared())
            })
            .expect("a body is the fastest");
        let path = KeyPath::of("bodies").index(index).key("velocity");
        let slower = speed_budget - f64::from(first.wave_speed);
        let hint = if slower > 0.0 {
            format!(
                "give it at most {} m/s, use a larger cell_size, {raise}",
                Num(slower)
            )
        } else {
            format!("give it a lower speed and use a larger cell_size, {raise}")
        };
        return Err(Issue::new(
            path.clone(),
            format!(
                "{path} is {} m/s: {step}",
                Num(body.velocity.as_dvec3().length())
            ),
            hint,
        ));
    }
    let stiffest = scene
        .bodies
        .iter()
        .filter_map(|body| scene.materials.get(body.material))
        .max_by(|a, b| {
            let speed = |m: &Material| {
                let (mu, lambda) = m.lame();
                (lambda + 2.0 * mu) / m.density
            };
            speed(a).total_cmp(&speed(b))
        })
        .expect("a body's material is the stiffest");
    let path = KeyPath::of("materials").key(&stiffest.name);
    Err(Issue::new(
        path.key("youngs_modulus"),
        format!(
            "{path} carries elastic waves at {} m/s (E = {} Pa, density {} kg/m³): {step}",
            Num::from(first.wave_speed),
            Num::from(stiffest.youngs_modulus),
            Num::from(stiffest.density)
        ),
        format!(
            "use a softer material (lower youngs_modulus), integrator = \"semi-implicit\" in \
             [solver] (elastic waves do not limit its step), a larger cell_size, {raise}"
        ),
    ))
}

/// `value` rounded up to three significant digits, for limits in hints.
fn round_up_3_digits(value: f64) -> Num {
    if !(value.is_finite() && value > 0.0) {
        return Num(value);
    }
    let unit = 10f64.powf(value.log10().floor() - 2.0);
    Num((value / unit).ceil() * unit)
}

/// Centre and radius of a ball-shaped body or collider.
fn check_ball(path: &KeyPath, center: Vec3, radius: f32) -> Check {
    finite_vec(center, path.key("center"))?;
    positive(
        radius,
        path.key("radius"),
        "set the radius in metres, e.g. radius = 0.1".to_string(),
    )?;
    Ok(())
}

/// Centre and edge lengths of a box-shaped body or collider.
fn check_box(path: &KeyPath, center: Vec3, size: Vec3) -> Check {
    finite_vec(center, path.key("center"))?;
    positive_vec(
        size,
        path.key("size"),
        "set the edge lengths in metres, e.g. size = [0.2, 0.2, 0.2]".to_string(),
    )?;
    Ok(())
}

fn check_collider(path: &KeyPath, collider: &Collider) -> Check {
    match collider.geometry {
        ColliderGeometry::HalfPlane { point, normal } => {
            finite_vec(point, path.key("point"))?;
            unit_vec(normal, path.key("normal"))?;
        }
        ColliderGeometry::Sphere { center, radius } => {
            check_ball(path, center, radius)?;
        }
        ColliderGeometry::Box { center, size } => {
            check_box(path, center, size)?;
        }
        ColliderGeometry::Mesh(ref mesh) => {
            check_mesh_placement(path, &mesh.placement)?;
            check_sdf_spacing(path, mesh.sdf_spacing)?;
        }
    }
    check_contact(path, &collider.contact)?;
    match &collider.motion {
        Motion::Static => {}
        Motion::Linear { velocity } => finite_vec(*velocity, path.key("velocity"))?,
        Motion::Keyframed { keys } => {
            let keys_path = path.key("keyframes");
            if keys.len() < 2 {
                return Err(Issue::new(
                    keys_path.clone(),
                    format!("{keys_path} needs at least 2 keys (got {})", keys.len()),
                    "give at least a start and an end key, e.g. keyframes = [{ time = 0.0, \
                     position = [1.0, 0.5, 1.0] }, { time = 1.0, position = [1.0, 1.5, 1.0] }]",
                ));
            }
            for (index, key) in keys.iter().enumerate() {
                let key_path = keys_path.index(index);
                ensure(
                    key.time.is_finite(),
                    key_path.key("time"),
                    "finite",
                    Num(key.time),
                    "give the key's time in seconds, e.g. time = 0.5".to_string(),
                )?;
                finite_vec(key.position, key_path.key("position"))?;
                if index > 0 && key.time <= keys[index - 1].time {
                    let time_path = key_path.key("time");
                    return Err(Issue::new(
                        time_path.clone(),
                        format!(
                            "{time_path} must be later than the key before it ({} <= {})",
                            Num(key.time),
                            Num(keys[index - 1].time)
                        ),
                        "list keyframes in strictly increasing time order",
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_output(output: &OutputSettings) -> Check {
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

fn check_vdb(vdb: &VdbSettings, cell_size: f32) -> Check {
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

fn check_mesh(mesh: &MeshSettings, cell_size: f32) -> Check {
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

fn check_camera(camera: &Camera) -> Check {
    let path = KeyPath::of("camera");
    if let Some(position) = camera.position {
        finite_vec(position, path.key("position"))?;
    }
    if let Some(look_at) = camera.look_at {
        finite_vec(look_at, path.key("look_at"))?;
    }
    if let (Some(position), Some(look_at)) = (camera.position, camera.look_at) {
        ensure(
            position.distance(look_at) > 0.0,
            path.key("look_at"),
            "away from camera.position",
            format_vec(look_at),
            "look at a point in front of the camera, e.g. the centre of the snow".to_string(),
        )?;
    }
    ensure(
        camera.fov_degrees > 1.0 && camera.fov_degrees < 170.0,
        path.key("fov"),
        "between 1 and 170 degrees",
        Num::from(camera.fov_degrees),
        "use a vertical field of view such as fov = 40".to_string(),
    )?;
    if let Some(orbit) = camera.orbit {
        ensure(
            orbit.degrees_per_second.is_finite(),
            path.key("orbit"),
            "a finite number of degrees per second",
            Num::from(orbit.degrees_per_second),
            "e.g. orbit = 30.0".to_string(),
        )?;
    }
    for (index, key) in camera.path.iter().enumerate() {
        let at = path.key("path").index(index);
        finite_vec(key.position, at.key("position"))?;
        finite_vec(key.look_at, at.key("look_at"))?;
        ensure(
            key.position.distance(key.look_at) > 0.0,
            at.key("look_at"),
            "away from the eye position",
            format_vec(key.look_at),
            "look at a point in front of the camera".to_string(),
        )?;
        if index > 0 {
            ensure(
                key.time > camera.path[index - 1].time,
                at.key("time"),
                "later than the previous key's time",
                Num::from(key.time),
                "list the camera path keys in increasing time".to_string(),
            )?;
        }
    }
    Ok(())
}

fn check_render(render: &RenderSettings) -> Check {
    let path = KeyPath::of("render");
    let [width, height] = render.size;
    ensure(
        (16..=8192).contains(&width) && (16..=8192).contains(&height),
        path.key("size"),
        "between 16 and 8192 pixels on each side",
        format!("[{width}, {height}]"),
        "e.g. size = [960, 540]".to_string(),
    )?;
    if let Some(index) = first_duplicate(&render.styles) {
        let at = path.key("styles").index(index);
        return Err(Issue::new(
            at.clone(),
            format!("{at} lists a style twice"),
            "list each style once, e.g. styles = [\"points\", \"volume\"]",
        ));
    }
    if let Some(radius) = render.point_radius {
        positive(
            radius,
            path.key("point_radius"),
            "give the sprite radius in metres, e.g. point_radius = 0.005".to_string(),
        )?;
    }
    ensure(
        (2..=256).contains(&render.trail_length),
        path.key("trail_length"),
        "between 2 and 256 positions",
        render.trail_length,
        "e.g. trail_length = 16".to_string(),
    )
}

/// Index of the first element equal to an earlier one.
fn first_duplicate<T: PartialEq>(items: &[T]) -> Option<usize> {
    (1..items.len()).find(|&i| items[..i].contains(&items[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_render_like_toml() {
        let path = KeyPath::of("bodies").index(1).key("radius");
        assert_eq!(path.to_string(), "bodies[1].radius");
        assert_eq!(
            KeyPath::of("materials").key("my snow").to_string(),
            "materials.\"my snow\""
        );
    }

    #[test]
    fn edit_distance_suggests_typos() {
        assert_eq!(edit_distance("radus", "radius"), 1);
        assert_eq!(closest("radus", &["center", "radius"]), Some("radius"));
        assert_eq!(closest("zzz", &["center", "radius"]), None);
    }

    #[test]
    fn line_column_counts_characters() {
        let source = Source {
            text: "a = 1\nλ = 2\n",
            origin: "x.toml",
        };
        assert_eq!(source.line_column(0), (1, 1));
        assert_eq!(source.line_column(6), (2, 1));
        assert_eq!(source.line_column(9), (2, 3));
    }
}
