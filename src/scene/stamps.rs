//! What a scene's parts were made from, to keep them while it stays: each file a description
//! reads with its modification time and length when it was read ([`Stamp`]), and the mesh
//! assets loaded for instances ([`CachedAsset`]). A live session's edit ([`super::edit`])
//! makes again what a changed stamp asks for; instancing ([`super::assets`]) keeps an asset
//! whose description and files stayed.

use super::components::LocalMesh;
use super::references::shape_files;
use crate::formats::access::SceneFiles;
use crate::formats::schema::ShapeDesc;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::SystemTime;

/// A file a description reads, with its modification time and length when it was read (`None`
/// if it could not be looked at): a description whose files' stamps changed is made again.
pub type Stamp = (PathBuf, Option<(SystemTime, u64)>);

pub(super) fn stamp(files: Vec<PathBuf>) -> Vec<Stamp> {
    files
        .into_iter()
        .map(|f| {
            let meta = std::fs::metadata(&f).ok();
            let when = meta.and_then(|m| Some((m.modified().ok()?, m.len())));
            (f, when)
        })
        .collect()
}

/// The stamps of the files of `stamps` now. (Looking again at the same files, not at what
/// the description names: finding an OBJ's material libraries reads the whole file, and a
/// file whose own stamp changed is read again anyway.)
pub(super) fn restamp(stamps: &[Stamp]) -> Vec<Stamp> {
    stamp(stamps.iter().map(|(f, _)| f.clone()).collect())
}

/// The stamps of the files the mesh asset `desc` reads, taken before it is read.
pub fn asset_stamps(desc: &ShapeDesc, files: &SceneFiles) -> Vec<Stamp> {
    stamp(shape_files(desc, files))
}

/// A mesh asset loaded for `Instance` shapes, kept while its description and file stay.
pub struct CachedAsset {
    pub name: String,
    pub desc: ShapeDesc,
    pub(super) stamps: Vec<Stamp>,
    pub mesh: Arc<LocalMesh>,
}

impl CachedAsset {
    /// The asset `name` of description `desc`, read from files of `stamps` (taken before it
    /// was read: a file written meanwhile is read again next time).
    pub fn new(name: &str, desc: &ShapeDesc, stamps: Vec<Stamp>, mesh: Arc<LocalMesh>) -> Self {
        CachedAsset {
            name: name.to_string(),
            desc: desc.clone(),
            stamps,
            mesh,
        }
    }

    /// Whether this is asset `name` as `desc` describes it now.
    pub fn matches(&self, name: &str, desc: &ShapeDesc) -> bool {
        self.name == name && self.desc == *desc && restamp(&self.stamps) == self.stamps
    }
}
