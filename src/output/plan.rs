//! The files a command reads and writes, checked before it starts: no output may be one of
//! the command's inputs or another of its outputs. Files are compared as the system sees
//! them, after links and relative paths (`./a.png`, `../out/a.png`, a symbolic link, a hard
//! link), so that `render scene.ron --checkpoint scene.ron` or `diff A B -o A` is refused
//! instead of destroying the scene or the image it was asked to read.

use super::atomic::{parent_dir, through_links};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// What the system calls one file.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Identity {
    /// An existing file: its device and inode (or, off Unix, its canonical path).
    Existing(u64, u64, PathBuf),
    /// A file that does not exist yet: the canonical folder and the name it will have there.
    New(PathBuf),
}

impl Identity {
    fn same_file(&self, other: &Identity) -> bool {
        match (self, other) {
            (Identity::Existing(d, i, p), Identity::Existing(e, j, q)) => {
                if cfg!(unix) {
                    (d, i) == (e, j)
                } else {
                    p == q
                }
            }
            (Identity::New(p), Identity::New(q)) => p == q,
            _ => false,
        }
    }
}

fn identity(path: &Path) -> Result<Identity> {
    let target = through_links(path)?;
    match std::fs::metadata(&target) {
        Ok(meta) => {
            let canonical = target.canonicalize().unwrap_or(target);
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                Ok(Identity::Existing(meta.dev(), meta.ino(), canonical))
            }
            #[cfg(not(unix))]
            {
                let _ = meta;
                Ok(Identity::Existing(0, 0, canonical))
            }
        }
        Err(_) => {
            // A new file: where it will be. The folder may be missing too (a compare folder
            // that is created later); then the path as given, made absolute.
            let dir = parent_dir(&target);
            let name = target.file_name().map(PathBuf::from).unwrap_or_default();
            let dir = dir
                .canonicalize()
                .or_else(|_| std::path::absolute(dir))
                .with_context(|| format!("{}: cannot resolve its folder", path.display()))?;
            Ok(Identity::New(dir.join(name)))
        }
    }
}

/// A file in a role: "the scene", "the output image", ...
struct Entry {
    role: String,
    path: PathBuf,
    identity: Identity,
}

/// The inputs and outputs of one command.
#[derive(Default)]
pub struct FilePlan {
    inputs: Vec<Entry>,
    outputs: Vec<Entry>,
}

impl FilePlan {
    pub fn new() -> FilePlan {
        FilePlan::default()
    }

    /// A file the command reads, in `role` ("the scene", "the reference image").
    pub fn input(&mut self, role: &str, path: &Path) -> Result<&mut FilePlan> {
        let identity = identity(path)?;
        self.inputs.push(Entry {
            role: role.into(),
            path: path.to_path_buf(),
            identity,
        });
        Ok(self)
    }

    /// A file the command writes, in `role` ("the image", "the checkpoint").
    pub fn output(&mut self, role: &str, path: &Path) -> Result<&mut FilePlan> {
        let identity = identity(path)?;
        self.outputs.push(Entry {
            role: role.into(),
            path: path.to_path_buf(),
            identity,
        });
        Ok(self)
    }

    /// Refuses the plan if an output is an input or another output.
    pub fn check(&self) -> Result<()> {
        for (k, out) in self.outputs.iter().enumerate() {
            for input in &self.inputs {
                if out.identity.same_file(&input.identity) {
                    bail!(
                        "{}: {} would overwrite {} ({}); choose another file",
                        out.path.display(),
                        out.role,
                        input.role,
                        input.path.display()
                    );
                }
            }
            for other in &self.outputs[..k] {
                if out.identity.same_file(&other.identity) {
                    bail!(
                        "{}: {} and {} are the same file; give them different names",
                        out.path.display(),
                        other.role,
                        out.role
                    );
                }
            }
        }
        Ok(())
    }
}
