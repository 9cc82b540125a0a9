//! The rules all tables share: required keys, vectors, and numbers (`ensure`, `positive`, `Num`).

use std::fmt;

use glam::Vec3;
use toml::Spanned;
use toml::de::DeValue;

use super::issue::{Check, Issue, KeyPath};
use super::messages::example;
use crate::scene::model;

pub(super) fn missing(key: KeyPath, what: &str) -> Issue {
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

pub(super) fn require<T>(value: Option<T>, key: KeyPath, what: &str) -> Result<T, Issue> {
    value.ok_or_else(|| missing(key, what))
}

/// Error for a key that the chosen shape does not take.
pub(super) fn reject<T>(value: &Option<T>, key: KeyPath, shape: &str, takes: &str) -> Check {
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

pub(super) fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

/// Normalise a direction, leaving the zero vector (an error the checks report).
pub(super) fn unit_or_zero(v: [f32; 3]) -> Vec3 {
    model::unit_or_zero(vec3(v))
}

/// `value` must satisfy `ok`; else "`path` must be `rule` (got value)".
pub(super) fn ensure(
    ok: bool,
    path: KeyPath,
    rule: &str,
    got: impl fmt::Display,
    hint: String,
) -> Check {
    if ok {
        Ok(())
    } else {
        let message = format!("{path} must be {rule} (got {got})");
        Err(Issue::new(path, message, hint))
    }
}

/// `value` (an `f32` or an `f64`) must be a finite number greater than 0.
pub(super) fn positive(value: impl Into<f64>, path: KeyPath, hint: String) -> Check {
    let value: f64 = value.into();
    let rule = if value.is_finite() {
        "greater than 0"
    } else {
        "a finite number greater than 0"
    };
    ensure(
        value > 0.0 && value.is_finite(),
        path,
        rule,
        Num(value),
        hint,
    )
}

pub(super) fn not_negative(value: f32, path: KeyPath, hint: String) -> Check {
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

pub(super) fn finite_vec(value: Vec3, path: KeyPath) -> Check {
    let leaf = path.leaf().unwrap_or("").to_string();
    let hint = match example(&leaf) {
        Some(example) => format!("use finite numbers, e.g. {example}"),
        None => "use finite numbers".to_string(),
    };
    ensure(value.is_finite(), path, "finite", format_vec(value), hint)
}

pub(super) fn positive_vec(value: Vec3, path: KeyPath, hint: String) -> Check {
    ensure(
        value.cmpgt(Vec3::ZERO).all() && value.is_finite(),
        path,
        "greater than 0 on every axis",
        format_vec(value),
        hint,
    )
}

/// A direction must be a non-zero unit vector.
pub(super) fn unit_vec(value: Vec3, path: KeyPath) -> Check {
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

pub(super) fn format_vec(v: Vec3) -> String {
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
pub(super) struct Num(pub(super) f64);

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

pub(super) const AXES: [&str; 3] = ["x", "y", "z"];

/// `value` rounded up to three significant digits, for limits in hints.
pub(super) fn round_up_3_digits(value: f64) -> Num {
    if !(value.is_finite() && value > 0.0) {
        return Num(value);
    }
    let unit = 10f64.powf(value.log10().floor() - 2.0);
    Num((value / unit).ceil() * unit)
}

/// Index of the first element equal to an earlier one.
pub(super) fn first_duplicate<T: PartialEq>(items: &[T]) -> Option<usize> {
    (1..items.len()).find(|&i| items[..i].contains(&items[i]))
}

/// Keys the format keeps as `f64`: `time.duration`, `time.fps`, and the
/// `time` of collider keyframes and of camera path keys. Every other number
/// is an `f32`.
const F64_KEYS: [&str; 3] = ["duration", "fps", "time"];

/// Every number kept as an `f32` must fit one: 1e300 would become infinite
/// and then fail a rule for the wrong reason ("at least ..."), so it is
/// refused here, as written. Run after deserialization, when every number
/// in the tree has been read into a number field.
pub(super) fn check_f32_range(root: &Spanned<DeValue<'_>>) -> Check {
    fn walk(node: &Spanned<DeValue<'_>>, path: &KeyPath) -> Check {
        match node.get_ref() {
            DeValue::Table(table) => {
                for (key, value) in table.iter() {
                    walk(value, &path.key(key.get_ref()))?;
                }
            }
            DeValue::Array(array) => {
                for (index, value) in array.iter().enumerate() {
                    walk(value, &path.index(index))?;
                }
            }
            DeValue::Float(float) if !F64_KEYS.contains(&path.leaf().unwrap_or("")) => {
                let value: f64 = float.as_str().parse().unwrap_or(0.0);
                if value.is_finite() && (value as f32).is_infinite() {
                    return Err(Issue::new(
                        path.clone(),
                        format!(
                            "{path} is too large (got {}): it is kept as a 32-bit float, at \
                             most {} in size",
                            Num(value),
                            Num::from(f32::MAX)
                        ),
                        "write a smaller number, in the unit docs/scene-format.md gives for \
                         the key",
                    ));
                }
            }
            _ => {}
        }
        Ok(())
    }
    walk(root, &KeyPath::root())
}
