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

/// An importer's places of entities and materials (see [`Origins`]) put into errors found
/// when its description is made into a world.
impl crate::formats::import::Origins {
    /// `e` at the place its entity or material came from, if the importer made it.
    pub fn place(&self, e: SceneError) -> SceneError {
        let found = match &e {
            SceneError::Entity {
                entity, message, ..
            } => self
                .entities
                .get(entity)
                .map(|p| (p, format!("entity `{entity}`: {message}"))),
            SceneError::Material {
                material, message, ..
            } => self
                .materials
                .get(material)
                .map(|p| (p, format!("material `{material}`: {message}"))),
            _ => None,
        };
        match found {
            Some(((path, line, col), message)) if !path.as_os_str().is_empty() => {
                SceneError::Parse {
                    path: path.clone(),
                    line: *line as usize,
                    col: *col as usize,
                    message,
                }
            }
            _ => e,
        }
    }
}
