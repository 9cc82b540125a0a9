//! `firn.Scene`: a scene as the TOML format describes it, loaded from a file,
//! the bundled default, or Python dicts with the same keys, always valid.
//!
//! The scene keeps its TOML document beside the validated scene, so that any
//! key can be read and changed by its path (`scene["material.hardening"]`,
//! `scene["bodies[0].velocity"]`); a change is validated by the same code as
//! a file, and a change that is not valid raises `SceneError` and is not
//! kept.

use std::path::PathBuf;

use firn_core::Scene;
use firn_core::scene::{SceneError, SceneKind};
use pyo3::exceptions::{PyKeyError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml::de::{DeTable, DeValue};
use toml::{Spanned, Table, Value};

use crate::errors::scene_error;

/// The bundled default scene, `firn run`'s own.
const DEFAULT_SCENE: &str = include_str!("../../scenes/snowball-wall.toml");

/// A valid scene and the TOML document it was read from.
#[pyclass(name = "Scene", module = "firn")]
#[derive(Clone)]
pub struct PyScene {
    /// The document, as the keys of the scene format.
    document: Table,
    /// Where it came from: a file's path (relative paths in the scene are
    /// taken from its folder) or `<dict>`.
    origin: String,
    /// The file's own text, for a scene read from a file: errors name its
    /// lines.
    file_text: Option<String>,
    /// The validated scene.
    pub scene: Scene,
}

impl PyScene {
    /// Parses and validates a file's `text`, naming `origin` in errors.
    fn parse(py: Python<'_>, text: &str, origin: &str) -> PyResult<PyScene> {
        PyScene::parse_document(py, text, origin, Some(text))
    }

    /// Parses and validates `text`, the TOML of a document that was read
    /// from `file_text` (where there is one) and changed from Python; an
    /// error names the file's line of its key where the file set it, or
    /// the key and the value set from Python.
    fn parse_document(
        py: Python<'_>,
        text: &str,
        origin: &str,
        file_text: Option<&str>,
    ) -> PyResult<PyScene> {
        let scene = Scene::from_toml_str(text, origin)
            .map_err(|error| scene_error(py, &placed(error, text, file_text)))?;
        let document = text.parse::<Table>().map_err(|error| {
            scene_error(
                py,
                &firn_core::scene::SceneError {
                    file: origin.into(),
                    line: None,
                    column: None,
                    key: None,
                    message: error.to_string(),
                    hint: "write valid TOML".into(),
                },
            )
        })?;
        Ok(PyScene {
            document,
            origin: origin.into(),
            file_text: file_text.map(str::to_string),
            scene,
        })
    }

    /// The scene of `document`, changed from Python, validated as if it
    /// were read from a file; `file_text` is the file it was first read
    /// from, if any.
    fn from_document(
        py: Python<'_>,
        document: Table,
        origin: &str,
        file_text: Option<&str>,
    ) -> PyResult<PyScene> {
        let text =
            toml::to_string(&document).map_err(|error| PyTypeError::new_err(error.to_string()))?;
        PyScene::parse_document(py, &text, origin, file_text)
    }
}

#[pymethods]
impl PyScene {
    /// Loads and validates a scene file (TOML).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyScene> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(&path).map_err(|error| {
            scene_error(
                py,
                &firn_core::scene::SceneError {
                    file: origin.clone(),
                    line: None,
                    column: None,
                    key: None,
                    message: format!("cannot read scene file '{origin}': {error}"),
                    hint: "check the path".into(),
                },
            )
        })?;
        PyScene::parse(py, &text, &origin)
    }

    /// The bundled default scene (`firn run` without a scene file).
    #[staticmethod]
    fn default(py: Python<'_>) -> PyResult<PyScene> {
        PyScene::parse(py, DEFAULT_SCENE, "snowball-wall.toml")
    }

    /// A scene from nested dicts and lists with the keys of the TOML format.
    /// Errors name `origin`, the key and the value given.
    #[staticmethod]
    #[pyo3(signature = (values, origin = "<dict>"))]
    fn from_dict(py: Python<'_>, values: &Bound<'_, PyDict>, origin: &str) -> PyResult<PyScene> {
        let document = table_from_dict(values, "")?;
        PyScene::from_document(py, document, origin, None)
    }

    /// The scene's keys as nested dicts and lists.
    fn to_dict(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_python(py, &Value::Table(self.document.clone()))
    }

    /// The scene as TOML text.
    fn to_toml(&self) -> PyResult<String> {
        toml::to_string(&self.document).map_err(|error| PyTypeError::new_err(error.to_string()))
    }

    /// Checks the scene again (it is always valid: every change is checked).
    fn validate(&self, py: Python<'_>) -> PyResult<()> {
        self.scene
            .validate()
            .map_err(|error| scene_error(py, &error))
    }

    /// The value at a key path such as `"material.hardening"` or
    /// `"bodies[0].velocity"`, as written in the scene (defaults are not
    /// filled in).
    fn __getitem__(&self, py: Python<'_>, path: &str) -> PyResult<Py<PyAny>> {
        to_python(py, lookup(&self.document, path)?)
    }

    /// Sets the value at a key path (creating tables on the way) and checks
    /// the scene; raises `SceneError` and keeps the old value if the new
    /// scene is not valid.
    fn __setitem__(
        &mut self,
        py: Python<'_>,
        path: &str,
        value: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let mut document = self.document.clone();
        set_path(&mut document, path, to_toml(value, path)?)?;
        *self = PyScene::from_document(py, document, &self.origin, self.file_text.as_deref())?;
        Ok(())
    }

    /// Whether a key path is set in the scene.
    fn __contains__(&self, path: &str) -> bool {
        lookup(&self.document, path).is_ok()
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// `"snow"` or `"flow"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.scene.kind {
            SceneKind::Snow => "snow",
            SceneKind::Flow(_) => "flow",
        }
    }

    /// Frames per second of the output.
    #[getter]
    fn fps(&self) -> f64 {
        self.scene.time.fps
    }

    /// Simulated seconds.
    #[getter]
    fn duration(&self) -> f64 {
        self.scene.time.duration
    }

    /// Frames after frame 0.
    #[getter]
    fn frame_count(&self) -> u32 {
        self.scene.time.frame_count()
    }

    /// Where the scene came from.
    #[getter]
    fn origin(&self) -> String {
        self.origin.clone()
    }

    fn __repr__(&self) -> String {
        let cells = self.scene.domain.cells();
        format!(
            "<firn.Scene '{}' ({}): {} s at {} fps, {}x{}x{} cells of {} m, from {}>",
            self.scene.name,
            self.kind(),
            self.scene.time.duration,
            self.scene.time.fps,
            cells[0],
            cells[1],
            cells[2],
            self.scene.domain.cell_size,
            self.origin
        )
    }
}

/// `error`, found in `text` (the document as TOML), placed where the user
/// wrote its key: on the line of `file_text` that holds the key with the
/// value it still has, or else at no line, with the key and the value that
/// was set from Python.
fn placed(mut error: SceneError, text: &str, file_text: Option<&str>) -> SceneError {
    let Some(key) = error.key.clone().filter(|_| file_text != Some(text)) else {
        return error;
    };
    let Ok(document) = text.parse::<Table>() else {
        return error;
    };
    let now = lookup(&document, &key).ok();
    let in_file = file_text.and_then(|file| {
        let original = file.parse::<Table>().ok()?;
        let unchanged = lookup(&original, &key).ok() == now;
        unchanged.then(|| line_and_column(file, &key)).flatten()
    });
    match (in_file, now) {
        (Some((line, column)), _) => {
            error.line = Some(line);
            error.column = Some(column);
        }
        (None, Some(value)) => {
            error.line = None;
            error.column = None;
            error.message = format!(
                "{} (set from Python: {key} = {})",
                error.message,
                value_text(value)
            );
        }
        (None, None) => {
            error.line = None;
            error.column = None;
        }
    }
    error
}

/// A value as TOML writes it inline (`-1.0`, `[0.0, 1.0, 0.0]`).
fn value_text(value: &Value) -> String {
    let mut table = Table::new();
    table.insert("v".into(), value.clone());
    toml::to_string(&table).map_or_else(
        |_| value.to_string(),
        |line| line.trim().trim_start_matches("v = ").to_string(),
    )
}

/// 1-based line and column (in characters) of the value at key path `path`
/// in the TOML text `text`, if the text holds it.
fn line_and_column(text: &str, path: &str) -> Option<(usize, usize)> {
    let root = DeTable::parse(text).ok()?;
    let mut node = Spanned::new(root.span(), DeValue::Table(root.into_inner()));
    for (key, indices) in steps(path).ok()? {
        let DeValue::Table(table) = node.into_inner() else {
            return None;
        };
        node = table.get(key.as_str())?.clone();
        for index in indices {
            let DeValue::Array(array) = node.into_inner() else {
                return None;
            };
            node = array.get(index)?.clone();
        }
    }
    let before = &text[..node.span().start.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Some((line, before[line_start..].chars().count() + 1))
}

/// One step of a key path: a table key, then array indices.
fn steps(path: &str) -> PyResult<Vec<(String, Vec<usize>)>> {
    path.split('.')
        .map(|part| {
            let (key, rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
            let mut indices = Vec::new();
            for index in rest.split('[').filter(|s| !s.is_empty()) {
                let number = index.trim_end_matches(']').parse().map_err(|_| {
                    PyKeyError::new_err(format!("'{path}': '[{index}' is not an index like [0]"))
                })?;
                indices.push(number);
            }
            if key.is_empty() {
                return Err(PyKeyError::new_err(format!("'{path}' has an empty key")));
            }
            Ok((key.to_string(), indices))
        })
        .collect()
}

/// The value at `path` in `document`.
fn lookup<'a>(document: &'a Table, path: &str) -> PyResult<&'a Value> {
    let missing = || PyKeyError::new_err(format!("the scene does not set '{path}'"));
    let mut table = document;
    let steps = steps(path)?;
    let last = steps.len() - 1;
    for (position, (key, indices)) in steps.iter().enumerate() {
        let mut value = table.get(key).ok_or_else(missing)?;
        for &index in indices {
            value = value
                .as_array()
                .and_then(|array| array.get(index))
                .ok_or_else(missing)?;
        }
        if position == last {
            return Ok(value);
        }
        table = value.as_table().ok_or_else(missing)?;
    }
    Err(missing())
}

/// Sets `path` in `document` to `new`, creating tables on the way.
fn set_path(document: &mut Table, path: &str, new: Value) -> PyResult<()> {
    let steps = steps(path)?;
    let last = steps.len() - 1;
    let mut table = document;
    for (position, (key, indices)) in steps.into_iter().enumerate() {
        let mut slot = if indices.is_empty() && position == last {
            table.insert(key, new);
            return Ok(());
        } else {
            table
                .entry(key.clone())
                .or_insert_with(|| Value::Table(Table::new()))
        };
        for index in indices {
            slot = slot
                .as_array_mut()
                .and_then(|array| array.get_mut(index))
                .ok_or_else(|| {
                    PyKeyError::new_err(format!("'{path}': {key} has no item {index}"))
                })?;
        }
        if position == last {
            *slot = new;
            return Ok(());
        }
        table = slot
            .as_table_mut()
            .ok_or_else(|| PyKeyError::new_err(format!("'{path}': {key} is not a table")))?;
    }
    Ok(())
}

/// A dict as a TOML table; `path` names it in errors.
fn table_from_dict(dict: &Bound<'_, PyDict>, path: &str) -> PyResult<Table> {
    let mut table = Table::new();
    for (key, value) in dict.iter() {
        let key: String = key
            .extract()
            .map_err(|_| PyTypeError::new_err(format!("keys must be strings (in '{path}')")))?;
        let inner = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        table.insert(key, to_toml(&value, &inner)?);
    }
    Ok(table)
}

/// A Python value as a TOML value: bools, numbers (numpy's too), strings,
/// lists and tuples, dicts.
fn to_toml(value: &Bound<'_, PyAny>, path: &str) -> PyResult<Value> {
    if value.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() {
        return Ok(Value::Integer(value.extract()?));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(Value::String(value.extract()?));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        return Ok(Value::Table(table_from_dict(dict, path)?));
    }
    if value.is_instance_of::<PyList>()
        || value.is_instance_of::<PyTuple>()
        || value.hasattr("tolist")?
    {
        let items = if value.hasattr("tolist")? {
            value.call_method0("tolist")?
        } else {
            value.clone()
        };
        if !(items.is_instance_of::<PyList>() || items.is_instance_of::<PyTuple>()) {
            return to_toml(&items, path);
        }
        let mut array = Vec::new();
        for (index, item) in items.try_iter()?.enumerate() {
            array.push(to_toml(&item?, &format!("{path}[{index}]"))?);
        }
        return Ok(Value::Array(array));
    }
    Err(PyTypeError::new_err(format!(
        "'{path}': a {} cannot be a scene value (use numbers, strings, bools, lists and dicts)",
        value.get_type().name()?
    )))
}

/// A TOML value as a Python value.
fn to_python(py: Python<'_>, value: &Value) -> PyResult<Py<PyAny>> {
    Ok(match value {
        Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any().unbind(),
        Value::Integer(i) => i.into_pyobject(py)?.into_any().unbind(),
        Value::Float(f) => f.into_pyobject(py)?.into_any().unbind(),
        Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any().unbind(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_python(py, item)?)?;
            }
            list.into_any().unbind()
        }
        Value::Table(table) => {
            let dict = PyDict::new(py);
            for (key, item) in table {
                dict.set_item(key, to_python(py, item)?)?;
            }
            dict.into_any().unbind()
        }
    })
}
