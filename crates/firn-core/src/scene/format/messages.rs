//! Plain words for the deserializer's errors, with example lines and "did you mean" hints.

use super::issue::{KeyPath, Segment};

/// Reword the deserializer's message for a user, with a hint.
pub(super) fn describe_deserialize_error(message: &str, path: &KeyPath) -> (String, String) {
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
            Some("bodies") | Some("colliders") | Some("rigid_bodies") => {
                "an array of tables".to_string()
            }
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
const TABLES: [&str; 10] = [
    "domain",
    "time",
    "solver",
    "materials",
    "bodies",
    "colliders",
    "rigid_bodies",
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
            "bodies" | "colliders" | "rigid_bodies" => {
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
pub(super) fn example(leaf: &str) -> Option<&'static str> {
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
        "solid" => "solid = \"hull\"",
        "quaternion" => "quaternion = [0.0, 0.0, 0.0, 1.0]",
        "mass" => "mass = 20.0",
        "angular_velocity" => "angular_velocity = [0.0, 0.0, 0.0]",
        "restitution" => "restitution = 0.3",
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
pub(super) fn closest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_suggests_typos() {
        assert_eq!(edit_distance("radus", "radius"), 1);
        assert_eq!(closest("radus", &["center", "radius"]), Some("radius"));
        assert_eq!(closest("zzz", &["center", "radius"]), None);
    }
}
