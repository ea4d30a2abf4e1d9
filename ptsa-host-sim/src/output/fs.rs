//! Files that appear whole or not at all, with the modes every Unix tool gives them, and
//! nothing left behind: every file the host simulator writes goes through [`write_atomic`]
//! (a temporary file in the same folder, renamed into place), a long file streamed by its
//! writer through [`temp_beside`] and [`persist`], and a folder written as one piece (the
//! report) through [`StagedDir`].
//!
//! * **Modes.** Files are created as `0666` and folders as `0777` less the process umask
//!   (`0644`/`0755` under umask `022`), as `open(2)` and `mkdir(2)` make them; a file that
//!   replaces another keeps the other's mode.
//! * **Interruptions.** Every temporary file and staging folder is on a list of live
//!   temporaries until it is renamed into place or dropped. [`abandon`] removes everything on
//!   the list; the `ptsa` binary calls it from its SIGINT/SIGTERM/SIGHUP handler, so an
//!   interrupted run leaves neither a staging folder nor a temporary file, and the old
//!   output stays as it was. A folder's replacement ([`StagedDir::commit`]) holds the list's
//!   lock throughout, so a signal lands before or after it, never halfway.
//! * **Stale leftovers.** A run killed outright (SIGKILL, a power cut) cannot clean up: its
//!   temporaries carry its process id in their names (`.ptsa-staging-<pid>-…`,
//!   `.ptsa-old-<pid>-…`, `.ptsa-<pid>-…`), and the next run that writes into the same folder
//!   removes those whose process no longer exists ([`sweep_stale`]).
//! * **Inputs.** [`protect`] puts a file the run reads on a list; writing or replacing any
//!   path that is that same file (after links are resolved) is refused, so an output can
//!   never overwrite an input, whatever the command's own checks missed.

use std::collections::BTreeSet;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

use anyhow::{Context, Result, bail};

/// Prefix of every temporary name this module makes.
const PREFIX: &str = ".ptsa-";
/// The kinds of temporaries, after [`PREFIX`]: a staging folder, a folder moved aside while
/// it is replaced, a temporary file. Each is followed by `<pid>-`.
const KINDS: [&str; 3] = ["staging-", "old-", ""];

/// Temporaries of this process not yet renamed into place or removed.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Files this run reads, which nothing may overwrite, with what they are ("the file given to
/// --data").
static PROTECTED: Mutex<Vec<Protected>> = Mutex::new(Vec::new());

/// A file the run reads: the path it was given by, what that path was (device and inode, or
/// the resolved path) when it was protected, and what it is in messages.
struct Protected {
    path: PathBuf,
    id: FileId,
    what: String,
}
/// Folders already swept of stale temporaries by this process.
static SWEPT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic while the lock was held leaves a list that is still a list.
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Remove every live temporary of this process and return with the list locked, so that
/// nothing is renamed into place after it (a [`StagedDir::commit`] under way finishes first).
/// For a signal handler that then exits the process.
pub fn abandon() -> MutexGuard<'static, Vec<PathBuf>> {
    let mut live = lock(&LIVE);
    for p in live.drain(..) {
        remove_any(&p);
    }
    live
}

fn remove_any(p: &Path) {
    match std::fs::symlink_metadata(p) {
        Ok(m) if m.is_dir() => {
            // Another thread of the run may still be writing into the folder: a file renamed
            // in while it is emptied makes the last rmdir fail (ENOTEMPTY) and left the
            // folder behind (seen once in CI after an interrupted report). Try again, up to
            // about a tenth of a second, until it is gone.
            for _ in 0..100 {
                if std::fs::remove_dir_all(p).is_ok() || std::fs::symlink_metadata(p).is_err() {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
        }
        Ok(_) => {
            let _ = std::fs::remove_file(p);
        }
        Err(_) => {}
    }
}

fn unregister_in(live: &mut Vec<PathBuf>, p: &Path) {
    live.retain(|q| q != p);
}

/// A temporary's place on the live list, given up when dropped (after the temporary itself,
/// which is declared before it in the structs that hold one: fields drop in order).
#[derive(Debug)]
struct Live(PathBuf);

impl Live {
    /// `path`, just created while `live` was held, on the list.
    fn push(live: &mut Vec<PathBuf>, path: &Path) -> Self {
        live.push(path.to_path_buf());
        Self(path.to_path_buf())
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        unregister_in(&mut lock(&LIVE), &self.0);
    }
}

/// A file's identity: its device and inode where the platform has them, else its
/// canonical path.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileId {
    #[cfg(unix)]
    Inode(u64, u64),
    #[cfg_attr(unix, allow(dead_code, reason = "the fallback of other platforms"))]
    Path(PathBuf),
}

fn file_id(p: &Path) -> Option<FileId> {
    let m = std::fs::metadata(p).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        Some(FileId::Inode(m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = m;
        p.canonicalize().ok().map(FileId::Path)
    }
}

/// Whether `a` and `b` are the same existing file (links resolved: a symbolic link, a hard
/// link or another spelling of the same path).
#[must_use]
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (file_id(a), file_id(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// Put `path`, a file this run reads, on the list of files nothing may overwrite; `what`
/// says what it is in messages ("the file given to --data"). A path that does not exist is
/// ignored (reading it fails on its own).
pub fn protect(path: &Path, what: &str) {
    if let Some(id) = file_id(path) {
        let mut p = lock(&PROTECTED);
        // Entries whose path no longer holds their file protect nothing, and their
        // identity may now be this file's.
        p.retain(|q| file_id(&q.path).as_ref() == Some(&q.id));
        if !p.iter().any(|q| q.id == id) {
            p.push(Protected {
                path: path.to_path_buf(),
                id,
                what: what.to_string(),
            });
        }
    }
}

/// What `path` is when it is a file the run reads ([`protect`]). A protected path that no
/// longer is the file it was (removed, or replaced by another) protects nothing: the inode
/// of a removed file may be given to a new one.
#[must_use]
pub fn input_named(path: &Path) -> Option<String> {
    let id = file_id(path)?;
    lock(&PROTECTED)
        .iter()
        .find(|q| q.id == id && file_id(&q.path).as_ref() == Some(&q.id))
        .map(|q| q.what.clone())
}

/// Refuse to write `path` when it is a file the run reads ([`protect`]).
///
/// # Errors
/// `path` is a protected input.
pub fn check_not_input(path: &Path) -> Result<()> {
    if let Some(what) = input_named(path) {
        bail!(
            "{}: this is {what}, an input of the run; an output never replaces an input (expected another name for the output)",
            path.display()
        );
    }
    Ok(())
}

/// The first protected input ([`protect`]) found anywhere inside `dir`, with what it is.
#[must_use]
pub fn input_inside(dir: &Path) -> Option<(PathBuf, String)> {
    if lock(&PROTECTED).is_empty() {
        return None;
    }
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            match e.file_type() {
                Ok(t) if t.is_dir() => stack.push(p),
                _ => {
                    if let Some(w) = input_named(&p) {
                        return Some((p, w));
                    }
                }
            }
        }
    }
    None
}

/// Whether process `pid` still exists (Linux's `/proc`); `None` where that cannot be told.
fn process_exists(pid: u32) -> Option<bool> {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return None;
    }
    Some(proc.join(pid.to_string()).exists())
}

/// The process id in a temporary's name, if the name is one of this module's.
fn owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(PREFIX)?;
    KINDS.iter().find_map(|k| {
        let r = rest.strip_prefix(k)?;
        let (pid, tail) = r.split_once('-')?;
        (!tail.is_empty() && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
            .then(|| pid.parse().ok())
            .flatten()
    })
}

/// Remove from `dir` the temporaries of this module's naming whose process no longer
/// exists (an earlier run that was killed before it could clean up); returns what was
/// removed. Each folder is swept once per process. Where process ids cannot be checked
/// (no `/proc`), nothing is removed.
pub fn sweep_stale(dir: &Path) -> Vec<PathBuf> {
    let key = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    if !lock(&SWEPT).insert(key) {
        return Vec::new();
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let me = std::process::id();
    let mut removed = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(owner) else {
            continue;
        };
        if pid != me && process_exists(pid) == Some(false) {
            let p = e.path();
            remove_any(&p);
            removed.push(p);
        }
    }
    removed
}

/// The folder a path's file goes into (`.` for a bare file name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The name prefix of this process's temporaries of `kind` (see [`KINDS`]).
fn prefix(kind: &str) -> String {
    format!("{PREFIX}{kind}{}-", std::process::id())
}

/// The mode a file written at `path` gets: that of the file it replaces, or `0666` (less the
/// umask, which `open(2)` applies).
#[cfg(unix)]
fn mode_for(path: &Path) -> std::fs::Permissions {
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::metadata(path)
        .ok()
        .filter(std::fs::Metadata::is_file)
        .map_or_else(
            || std::fs::Permissions::from_mode(0o666),
            |m| m.permissions(),
        )
}

/// A temporary file in `dir`, on the live list, created with the mode the file at `path`
/// should get.
fn temp_file_for(path: &Path, suffix: &str) -> Result<Temp> {
    let dir = parent_of(path);
    // The folder is made, and the file created and registered, under the list's lock: a
    // signal's clean-up ([`abandon`]) holds it from the moment it starts, so nothing can
    // make a folder again (a staging folder it has just removed, seen once in CI) nor leave
    // a file behind after it.
    let mut live = lock(&LIVE);
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    sweep_stale(dir);
    let prefix = prefix("");
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(suffix);
    #[cfg(unix)]
    b.permissions(mode_for(path));
    let f = b
        .tempfile_in(dir)
        .with_context(|| format!("cannot write in {}", dir.display()))?;
    let l = Live::push(&mut live, f.path());
    Ok(Temp { file: f, _live: l })
}

/// A temporary file that is removed when dropped or on a signal ([`abandon`]), until
/// [`persist`] renames it into place.
#[derive(Debug)]
pub struct Temp {
    file: tempfile::NamedTempFile,
    _live: Live,
}

impl Temp {
    /// The open file.
    #[must_use]
    pub fn as_file(&self) -> &std::fs::File {
        self.file.as_file()
    }

    /// Its (temporary) path.
    #[must_use]
    pub fn path(&self) -> &Path {
        self.file.path()
    }
}

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then a rename,
/// so a reader never sees half a file and a failure leaves the old file (or none).
///
/// # Errors
/// `path` is an input of the run ([`protect`]), or the folder cannot be created or the file
/// cannot be written; the message names the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    check_not_input(path)?;
    let mut tmp = temp_file_for(path, "")?;
    tmp.file
        .write_all(bytes)
        .with_context(|| format!("cannot write {}", path.display()))?;
    persist(tmp, path)
}

/// A temporary file beside `path` with the same extension, for writers that need a path
/// (the PNG encoder) or stream a long file; [`persist`] renames it into place.
///
/// # Errors
/// `path` is an input of the run, or the folder cannot be created or written.
pub fn temp_beside(path: &Path) -> Result<Temp> {
    check_not_input(path)?;
    let suffix = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    temp_file_for(path, &suffix)
}

/// Rename a file made by [`temp_beside`] into place.
///
/// # Errors
/// `path` is an input of the run, or the rename fails.
pub fn persist(tmp: Temp, path: &Path) -> Result<()> {
    check_not_input(path)?;
    // Off the live list only after the rename: a signal's clean-up in between finds nothing
    // at the temporary path, and the file is in place.
    let Temp { file, _live } = tmp;
    file.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Put the folder `staged` at `target`, moving an existing `target` aside into a folder of
/// its own (returned, on the live list, for the caller to remove). On failure the old folder
/// is put back, the staged one removed, and both are off the list. `live` is the locked list.
fn replace(live: &mut Vec<PathBuf>, staged: &Path, target: &Path) -> Result<Option<PathBuf>> {
    let fail = |live: &mut Vec<PathBuf>, aside: Option<&Path>| {
        if let Some(a) = aside {
            let _ = std::fs::rename(a.join("old"), target);
            remove_any(a);
            unregister_in(live, a);
        }
        remove_any(staged);
        unregister_in(live, staged);
    };
    let aside = if target.exists() {
        let aside = match tempfile::Builder::new()
            .prefix(&prefix("old-"))
            .tempdir_in(parent_of(target))
        {
            Ok(a) => a.keep(),
            Err(e) => {
                fail(live, None);
                return Err(e).with_context(|| format!("cannot write beside {}", target.display()));
            }
        };
        live.push(aside.clone());
        if let Err(e) = std::fs::rename(target, aside.join("old")) {
            fail(live, Some(&aside));
            return Err(e).with_context(|| format!("cannot move {} aside", target.display()));
        }
        Some(aside)
    } else {
        None
    };
    if let Err(e) = std::fs::rename(staged, target) {
        fail(live, aside.as_deref());
        return Err(e).with_context(|| format!("cannot create {}", target.display()));
    }
    unregister_in(live, staged);
    Ok(aside)
}

/// A folder written as one piece: everything goes into a temporary folder beside the target,
/// which [`StagedDir::commit`] renames into place (replacing an older one). Dropped without
/// a commit (or on a signal: [`abandon`]), the temporary folder is removed and the target is
/// untouched.
#[derive(Debug)]
pub struct StagedDir {
    tmp: tempfile::TempDir,
    live: Live,
    target: PathBuf,
}

impl StagedDir {
    /// Stage a folder that will become `target`. Stale temporaries of killed runs beside it
    /// are removed first ([`sweep_stale`]).
    ///
    /// # Errors
    /// The parent folder cannot be created or written.
    pub fn new(target: &Path) -> Result<Self> {
        let parent = parent_of(target);
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
        sweep_stale(parent);
        let prefix = prefix("staging-");
        let mut live = lock(&LIVE);
        let tmp = tempfile::Builder::new()
            .prefix(&prefix)
            .tempdir_in(parent)
            .with_context(|| format!("cannot write in {}", parent.display()))?;
        let live = Live::push(&mut live, tmp.path());
        Ok(Self {
            tmp,
            live,
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
    /// folder is at `target`, never a mixture. The list of live temporaries stays locked
    /// throughout, so that a signal's clean-up ([`abandon`]) comes before or after, never
    /// between the two renames.
    ///
    /// # Errors
    /// The target is a file (it is never replaced by a folder), it holds an input of the run
    /// ([`protect`]), or a rename fails (the old folder is then left in place).
    pub fn commit(self) -> Result<PathBuf> {
        if self.target.is_file() {
            bail!(
                "{} is a file; expected a folder (or a name for a new one)",
                self.target.display()
            );
        }
        if let Some((p, what)) = input_inside(&self.target) {
            bail!(
                "{}: holds {} ({what}, an input of the run); the folder is replaced as a whole and it would be deleted",
                self.target.display(),
                p.display()
            );
        }
        let Self {
            tmp,
            live: entry,
            target,
        } = self;
        let staged = tmp.keep();
        let mut live = lock(&LIVE);
        let r = replace(&mut live, &staged, &target);
        drop(live);
        drop(entry);
        if let Some(aside) = r? {
            remove_any(&aside);
            unregister_in(&mut lock(&LIVE), &aside);
        }
        Ok(target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An input protects the file at the path it was given by while it is there: once that
    /// path holds nothing (here the file moved away, as a removed file's inode may be given
    /// to a new file), the identity protects nothing. Under a live path, a hard link to the
    /// input is refused.
    #[test]
    fn a_protected_path_protects_the_file_while_it_is_there() {
        let d = tempfile::tempdir().unwrap();
        let (input, link, moved) = (
            d.path().join("in.csv"),
            d.path().join("link.csv"),
            d.path().join("moved.csv"),
        );
        std::fs::write(&input, b"measured").unwrap();
        protect(&input, "the test's moved input");
        std::fs::hard_link(&input, &link).unwrap();
        assert!(check_not_input(&link).is_err());
        std::fs::remove_file(&link).unwrap();
        std::fs::rename(&input, &moved).unwrap();
        assert_eq!(input_named(&moved), None);
        check_not_input(&moved).unwrap();
    }

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

    #[test]
    fn temporaries_are_known_by_their_process_id() {
        assert_eq!(owner(".ptsa-staging-123-a1B2c3"), Some(123));
        assert_eq!(owner(".ptsa-old-5-x"), Some(5));
        assert_eq!(owner(".ptsa-77-xyz.csv"), Some(77));
        for other in [
            ".ptsa-notes",
            ".ptsa-staging-abc",
            ".ptsa-staging-12-",
            ".ptsa--1-x",
            "ptsa-staging-1-x",
            ".ptsa-x1-y",
        ] {
            assert_eq!(owner(other), None, "{other}");
        }
    }

    #[test]
    fn an_input_is_never_written_nor_deleted_with_its_folder() {
        let d = tempfile::tempdir().unwrap();
        let input = d.path().join("in.csv");
        std::fs::write(&input, b"measured").unwrap();
        protect(&input, "the test's input");
        let link = d.path().join("link.csv");
        std::fs::hard_link(&input, &link).unwrap();
        for p in [&input, &link] {
            let e = write_atomic(p, b"x").unwrap_err();
            assert!(format!("{e}").contains("the test's input"), "{e}");
        }
        // A folder replaced as a whole that holds it.
        let target = d.path().join("r");
        std::fs::create_dir(&target).unwrap();
        std::fs::rename(&link, target.join("kept.csv")).unwrap();
        let s = StagedDir::new(&target).unwrap();
        let e = s.commit().unwrap_err();
        assert!(format!("{e}").contains("kept.csv"), "{e}");
        assert_eq!(std::fs::read(target.join("kept.csv")).unwrap(), b"measured");
        assert_eq!(std::fs::read(&input).unwrap(), b"measured");
    }
}
