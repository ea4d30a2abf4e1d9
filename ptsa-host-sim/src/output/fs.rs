//! Files that appear whole or not at all: every file the host simulator writes goes through
//! [`write_atomic`] (a temporary file in the same folder, renamed into place), and a folder
//! written as one piece (the report) through [`StagedDir`].

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The folder a path's file goes into (`.` for a bare file name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then a rename,
/// so a reader never sees half a file and a failure leaves the old file (or none).
///
/// # Errors
/// The folder cannot be created or the file cannot be written; the message names the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = parent_of(path);
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".ptsa-")
        .tempfile_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))?;
    tmp.write_all(bytes)
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// A temporary file beside `path` with the same extension, for writers that need a path
/// (the PNG encoder); [`persist`] renames it into place.
///
/// # Errors
/// The folder cannot be created or written.
pub fn temp_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = parent_of(path);
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let suffix = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    tempfile::Builder::new()
        .prefix(".ptsa-")
        .suffix(&suffix)
        .tempfile_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))
}

/// Rename a file made by [`temp_beside`] into place.
///
/// # Errors
/// The rename fails.
pub fn persist(tmp: tempfile::NamedTempFile, path: &Path) -> Result<()> {
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// A folder written as one piece: everything goes into a temporary folder beside the target,
/// which [`StagedDir::commit`] renames into place (replacing an older one). Dropped without
/// a commit, the temporary folder is removed and the target is untouched.
#[derive(Debug)]
pub struct StagedDir {
    tmp: tempfile::TempDir,
    target: PathBuf,
}

impl StagedDir {
    /// Stage a folder that will become `target`.
    ///
    /// # Errors
    /// The parent folder cannot be created or written.
    pub fn new(target: &Path) -> Result<Self> {
        let parent = parent_of(target);
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
        let tmp = tempfile::Builder::new()
            .prefix(".ptsa-staging-")
            .tempdir_in(parent)
            .with_context(|| format!("cannot write in {}", parent.display()))?;
        Ok(Self {
            tmp,
            target: target.to_path_buf(),
        })
    }

    /// Where to write now.
    #[must_use]
    pub fn path(&self) -> &Path {
        self.tmp.path()
    }

    /// The folder it will become.
    #[must_use]
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Put the staged folder in place of the target: an existing target is moved aside
    /// first and removed after the rename, so at every moment either the old or the new
    /// folder is at `target`, never a mixture.
    ///
    /// # Errors
    /// The target is a file (it is never replaced by a folder), or a rename fails (the old
    /// folder is then left in place).
    pub fn commit(self) -> Result<PathBuf> {
        if self.target.is_file() {
            anyhow::bail!(
                "{} is a file; expected a folder (or a name for a new one)",
                self.target.display()
            );
        }
        let staged = self.tmp.keep();
        let target = self.target;
        let old = if target.exists() {
            let aside = tempfile::Builder::new()
                .prefix(".ptsa-old-")
                .tempdir_in(parent_of(&target))
                .with_context(|| format!("cannot write beside {}", target.display()))?
                .keep();
            let aside = aside.join("old");
            std::fs::rename(&target, &aside)
                .with_context(|| format!("cannot move {} aside", target.display()))?;
            Some(aside)
        } else {
            None
        };
        if let Err(e) = std::fs::rename(&staged, &target) {
            if let Some(a) = &old {
                let _ = std::fs::rename(a, &target);
            }
            let _ = std::fs::remove_dir_all(&staged);
            return Err(e).with_context(|| format!("cannot create {}", target.display()));
        }
        if let Some(a) = old.as_deref().and_then(Path::parent) {
            let _ = std::fs::remove_dir_all(a);
        }
        Ok(target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.csv");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn staged_dir_appears_whole_or_not_at_all() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("report");
        // Not committed: nothing appears.
        {
            let s = StagedDir::new(&target).unwrap();
            write_atomic(&s.path().join("x.csv"), b"1").unwrap();
        }
        assert!(!target.exists());
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
        // Committed over an older folder: only the new files remain.
        std::fs::create_dir_all(&target).unwrap();
        std::fs::write(target.join("stale.csv"), b"old").unwrap();
        let s = StagedDir::new(&target).unwrap();
        write_atomic(&s.path().join("x.csv"), b"2").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(target.join("x.csv")).unwrap(), b"2");
        assert!(!target.join("stale.csv").exists());
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
    }
}
