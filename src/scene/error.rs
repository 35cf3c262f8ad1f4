//! Errors of loading a scene: each names the file and the line:column, the entity, the
//! material or the camera at fault.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    // Not a `source`: the message already holds the reason, and error chains would repeat it.
    #[error("{}: cannot read scene file: {reason}", path.display())]
    Read {
        path: PathBuf,
        reason: std::io::Error,
    },
    #[error("{}:{line}:{col}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        col: usize,
        message: String,
    },
    #[error("{}: entity `{entity}`: {message}", path.display())]
    Entity {
        path: PathBuf,
        entity: String,
        message: String,
    },
    #[error("{}: material `{material}`: {message}", path.display())]
    Material {
        path: PathBuf,
        material: String,
        message: String,
    },
    #[error("{}: camera: {message}", path.display())]
    Camera { path: PathBuf, message: String },
    #[error("{}: {message}", path.display())]
    Scene { path: PathBuf, message: String },
}

/// Checks that every number is finite, naming the field on failure.
pub(crate) fn finite(what: &str, values: &[f32]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite, got {values:?}"))
    }
}
