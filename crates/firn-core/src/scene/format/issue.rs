//! Key paths like `bodies[1].radius`, the issues found at them, and their place in the text.

use std::fmt;
use std::ops::Range;

use toml::Spanned;
use toml::de::DeValue;

use super::SceneError;
use super::messages::describe_deserialize_error;

/// One step of a key path: a table key or an array index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Segment {
    Key(String),
    Index(usize),
}

/// A path to a value in the scene, like `bodies[1].radius`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct KeyPath(pub(super) Vec<Segment>);

impl KeyPath {
    pub(super) fn root() -> KeyPath {
        KeyPath(Vec::new())
    }

    pub(super) fn of(key: &str) -> KeyPath {
        KeyPath::root().key(key)
    }

    pub(super) fn key(&self, key: &str) -> KeyPath {
        let mut path = self.clone();
        path.0.push(Segment::Key(key.to_string()));
        path
    }

    pub(super) fn index(&self, index: usize) -> KeyPath {
        let mut path = self.clone();
        path.0.push(Segment::Index(index));
        path
    }

    pub(super) fn parent(&self) -> KeyPath {
        let mut path = self.clone();
        path.0.pop();
        path
    }

    /// The last table key in the path, if any.
    pub(super) fn leaf(&self) -> Option<&str> {
        match self.0.last() {
            Some(Segment::Key(key)) => Some(key),
            _ => None,
        }
    }

    pub(super) fn is_root(&self) -> bool {
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
pub(super) struct Issue {
    /// The key the problem is about.
    pub(super) key: KeyPath,
    /// Where to point in the text, if not at `key` itself.
    at: Option<KeyPath>,
    pub(super) message: String,
    pub(super) hint: String,
}

impl Issue {
    pub(super) fn new(key: KeyPath, message: impl Into<String>, hint: impl Into<String>) -> Issue {
        Issue {
            key,
            at: None,
            message: message.into(),
            hint: hint.into(),
        }
    }

    /// Replace the hint.
    pub(super) fn with_hint(mut self, hint: &str) -> Issue {
        self.hint = hint.to_string();
        self
    }

    /// Point at `at` in the text instead of at the key.
    pub(super) fn pointing_at(mut self, at: KeyPath) -> Issue {
        self.at = Some(at);
        self
    }
}

pub(super) type Check = Result<(), Issue>;

// Locating issues in the text
// ---------------------------------------------------------------------------

/// The scene text and the name it is reported under.
pub(super) struct Source<'a> {
    pub(super) text: &'a str,
    pub(super) origin: &'a str,
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
    pub(super) fn locate(&self, root: &Spanned<DeValue<'_>>, issue: Issue) -> SceneError {
        let at = issue.at.as_ref().unwrap_or(&issue.key);
        let offset = span_of_path(root, at).start;
        self.error_at(
            offset,
            Some(issue.key.to_string()),
            issue.message,
            issue.hint,
        )
    }

    pub(super) fn syntax_error(&self, err: &toml::de::Error) -> SceneError {
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
    pub(super) fn deserialize_error(
        &self,
        root: &Spanned<DeValue<'_>>,
        err: &toml::de::Error,
    ) -> SceneError {
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
