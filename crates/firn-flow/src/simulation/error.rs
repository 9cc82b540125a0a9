//! [`FlowError`]: why a flow could not start, be restored or change.

use std::fmt;

use firn_core::scene::SceneError;

/// Why a flow could not start or be restored.
#[derive(Debug, Clone, PartialEq)]
pub enum FlowError {
    /// The scene is a snow scene.
    NotAFlowScene,
    /// The scene breaks a rule of the format.
    Scene(Box<SceneError>),
    /// A snapshot does not fit the scene it is restored into.
    SnapshotMismatch(String),
}

impl fmt::Display for FlowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlowError::NotAFlowScene => f.write_str(
                "the scene is a snow scene; a curl-noise flow needs kind = \"flow\" and a [flow] \
                 table",
            ),
            FlowError::Scene(error) => write!(f, "{error}"),
            FlowError::SnapshotMismatch(what) => {
                write!(f, "the checkpoint does not match the scene: {what}")
            }
        }
    }
}

impl std::error::Error for FlowError {}
