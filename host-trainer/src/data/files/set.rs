//! Output sets: several files of one directory replaced together (DESIGN §9).
//!
//! A command that writes several files (`train`: Model-H, Model-P, coefficients; `report`: its
//! pages, tables and figures; a `fleet` group; `recalibrate`; `golden`) stages every file of
//! the set under a temporary name in the target directory and replaces the old files only
//! when every one is complete. A sequence of renames is not atomic as a whole, so the set is
//! committed through a journal:
//!
//! 1. *Stage*: each file is written to `.fbg-tmp-<id>-<k>` and synced. A failure here (a body
//!    that fails, a full disk, a target that is a directory or one of the inputs) removes the
//!    temporaries; no old file has been touched.
//! 2. *Back up*: each existing target is hard-linked (copied where the file system has no hard
//!    links) to `.fbg-tmp-<id>-<k>.old`. A target that cannot be linked because it is immutable
//!    or append-only fails here, still before anything is replaced.
//! 3. *Commit point*: the journal (target, temporary and backup names) is written to a
//!    temporary, synced, and renamed to `.fbg-journal-<id>`; the directory is synced. From
//!    here the new set is the one that counts.
//! 4. *Replace*: each temporary is renamed over its target. If a rename fails, the journal is
//!    first renamed to `.fbg-rollback-<id>` (the decision to go back, atomic), then every
//!    target already replaced gets its backup back (or is removed when there was none), so
//!    the old set is whole again and the command fails.
//! 5. *Finish*: the directory is synced, the journal and the backups are removed.
//!
//! After a kill at any instruction the directory therefore holds the old set (no journal:
//! nothing was replaced, the temporaries are litter; or a rollback journal: the backups are
//! put back) or the new set (a journal: the remaining temporaries are renamed into place).
//! The next command that writes into the directory finishes that work before its own
//! ([`recover`]): it rolls a journal forward (back, when a rename fails again), rolls a
//! rollback journal back, and removes every `.fbg-tmp-*` left over.
//!
//! Concurrent writers (fleet groups in one directory, shards on shared storage) hold a shared
//! `flock` on the directory while they stage and commit; recovery runs only under an
//! exclusive lock taken without waiting, so it never removes a live writer's temporaries.
//! When the lock is busy the litter is left for a later run; where directories cannot be
//! locked (some network file systems), the set is still written and committed but no litter
//! is removed. A set of one file needs no journal: its rename is atomic.

use std::collections::HashSet;
use std::ffi::{OsStr, OsString};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use super::{clean_io, refuse_non_regular, FileId};
use crate::error::TrainerError;

/// Prefix of every temporary (staged file, backup, journal being written).
pub(crate) const TMP_PREFIX: &str = ".fbg-tmp-";
/// Prefix of a committed journal: its set is rolled forward.
pub(crate) const JOURNAL_PREFIX: &str = ".fbg-journal-";
/// Prefix of a journal being rolled back.
pub(crate) const ROLLBACK_PREFIX: &str = ".fbg-rollback-";
/// Format tag inside a journal.
const JOURNAL_FORMAT: &str = "fbg-trainer output set v1";

/// One file of a committed set, by names inside the directory.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Entry {
    target: String,
    tmp: String,
    /// The old target's backup, when there was an old target.
    backup: Option<String>,
}

#[derive(Serialize, Deserialize)]
struct Journal {
    format: String,
    entries: Vec<Entry>,
}

/// A set of files of one directory, replaced together by [`OutputSet::commit`]; dropped
/// without a commit, it removes its temporaries and leaves every old file as it was.
pub struct OutputSet {
    dir: PathBuf,
    /// The directory, open and under a shared lock while the set lives (none where the file
    /// system cannot lock it).
    lock: Option<File>,
    id: String,
    next: AtomicUsize,
    staged: Mutex<Vec<Entry>>,
    /// Files the set must never replace (the command's inputs).
    inputs: HashSet<FileId>,
}

fn unique_id() -> String {
    static COUNT: AtomicUsize = AtomicUsize::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    format!("{}-{:x}-{}", std::process::id(), nanos & 0xffff_ffff_ffff, COUNT.fetch_add(1, Ordering::Relaxed))
}

fn dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Directories this process already recovered: stale files only come from earlier runs, so
/// once per directory is enough (a fleet of 10 000 groups in one directory lists it once).
fn recovered() -> &'static Mutex<HashSet<PathBuf>> {
    static SEEN: std::sync::OnceLock<Mutex<HashSet<PathBuf>>> = std::sync::OnceLock::new();
    SEEN.get_or_init(|| Mutex::new(HashSet::new()))
}

impl OutputSet {
    /// A new set writing into `dir` (created when missing). Recovers what a killed run left
    /// in `dir` first (see the module doc), then holds a shared lock on it.
    pub fn in_dir(dir: &Path) -> Result<OutputSet, TrainerError> {
        let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
        std::fs::create_dir_all(dir).map_err(|e| TrainerError::io(dir, e))?;
        let lock = File::open(dir).ok();
        if let Some(f) = &lock {
            recover_with(f, dir)?;
            // Converts an exclusive lock, or waits for another process's recovery to end.
            let _ = f.lock_shared();
        }
        Ok(OutputSet {
            dir: dir.to_path_buf(),
            lock,
            id: unique_id(),
            next: AtomicUsize::new(0),
            staged: Mutex::new(Vec::new()),
            inputs: HashSet::new(),
        })
    }

    /// A set for the directory of `path` (as [`OutputSet::in_dir`]).
    pub fn beside(path: &Path) -> Result<OutputSet, TrainerError> {
        Self::in_dir(&dir_of(path))
    }

    /// Refuse to stage any file that is one of `inputs` (by device and inode): for commands
    /// whose output names are known only after reading (`report`).
    pub(crate) fn with_inputs(mut self, inputs: &[&Path]) -> Self {
        self.inputs.extend(inputs.iter().filter_map(|p| FileId::of(p)));
        self
    }

    /// The directory written.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn target_name<'a>(&self, target: &'a Path) -> Result<&'a OsStr, TrainerError> {
        let bad = |m: &str| TrainerError::Output { path: target.to_path_buf(), message: m.to_string() };
        let name = target.file_name().ok_or_else(|| bad("must name a file"))?;
        if dir_of(target) != self.dir {
            return Err(bad("internal: an output set writes one directory"));
        }
        if name.to_str().is_none() {
            return Err(bad("the file name is not valid UTF-8"));
        }
        Ok(name)
    }

    /// Stage `target` (a file in the set's directory): `body` writes its content to a
    /// temporary, synced before this returns. Nothing is replaced until [`commit`](Self::commit).
    pub fn stage(
        &self,
        target: &Path,
        body: impl FnOnce(&mut std::io::BufWriter<&mut File>) -> std::io::Result<()>,
    ) -> Result<(), TrainerError> {
        let name = self.target_name(target)?.to_string_lossy().into_owned();
        refuse_non_regular(target)?;
        if FileId::of(target).is_some_and(|id| self.inputs.contains(&id)) {
            return Err(TrainerError::Output {
                path: target.to_path_buf(),
                message: "the output is also an input; refusing to overwrite it (choose another output name)".into(),
            });
        }
        let k = self.next.fetch_add(1, Ordering::Relaxed);
        let tmp = format!("{TMP_PREFIX}{}-{k}", self.id);
        {
            let staged = self.staged.lock().map_err(|_| internal(target))?;
            if staged.iter().any(|e| e.target == name) {
                return Err(TrainerError::Output {
                    path: target.to_path_buf(),
                    message: "written twice in one output set".into(),
                });
            }
        }
        let tmp_path = self.dir.join(&tmp);
        let written = (|| {
            let mut opts = OpenOptions::new();
            opts.write(true).create_new(true);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                opts.mode(0o644);
            }
            let mut f = opts.open(&tmp_path)?;
            {
                let mut w = std::io::BufWriter::new(&mut f);
                body(&mut w)?;
                w.flush()?;
            }
            f.sync_all()
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp_path);
            return Err(TrainerError::io(target, clean_io(e)));
        }
        let mut staged = self.staged.lock().map_err(|_| internal(target))?;
        if staged.iter().any(|e| e.target == name) {
            let _ = std::fs::remove_file(&tmp_path);
            return Err(TrainerError::Output {
                path: target.to_path_buf(),
                message: "written twice in one output set".into(),
            });
        }
        staged.push(Entry { target: name, tmp, backup: None });
        Ok(())
    }

    /// Stage `bytes` as `target`.
    pub fn stage_bytes(&self, target: &Path, bytes: &[u8]) -> Result<(), TrainerError> {
        self.stage(target, |w| w.write_all(bytes))
    }

    /// Replace every staged target at once (see the module doc); on failure no old file is
    /// replaced.
    pub fn commit(self) -> Result<(), TrainerError> {
        let mut entries = match self.staged.lock() {
            Ok(mut s) => std::mem::take(&mut *s),
            Err(_) => return Err(internal(&self.dir)),
        };
        let result = self.commit_entries(&mut entries);
        // A journal still there (a rollback that could not finish) needs every temporary and
        // backup for the next run's recovery.
        let journal_left = [JOURNAL_PREFIX, ROLLBACK_PREFIX]
            .iter()
            .any(|p| std::fs::symlink_metadata(self.dir.join(format!("{p}{}", self.id))).is_ok());
        if result.is_err() && !journal_left {
            for e in &entries {
                let _ = std::fs::remove_file(self.dir.join(&e.tmp));
                if let Some(b) = &e.backup {
                    let _ = std::fs::remove_file(self.dir.join(b));
                }
            }
        }
        result
    }

    fn commit_entries(&self, entries: &mut [Entry]) -> Result<(), TrainerError> {
        let at = |name: &str| self.dir.join(name);
        for e in entries.iter() {
            refuse_non_regular(&at(&e.target))?;
        }
        if let [e] = entries {
            // One file: its rename is atomic, no journal needed.
            return std::fs::rename(at(&e.tmp), at(&e.target)).map_err(|err| TrainerError::io(&at(&e.target), err));
        }
        // 2. Backups of the old targets.
        for e in entries.iter_mut() {
            let target = at(&e.target);
            if std::fs::symlink_metadata(&target).is_err() {
                continue;
            }
            let backup = format!("{}.old", e.tmp);
            backup_file(&target, &at(&backup))?;
            e.backup = Some(backup);
        }
        // 3. The commit point.
        let journal = Journal { format: JOURNAL_FORMAT.into(), entries: entries.to_vec() };
        let text = serde_json::to_vec_pretty(&journal).map_err(|e| TrainerError::fit(e.to_string()))?;
        let jtmp = at(&format!("{TMP_PREFIX}{}-journal", self.id));
        let jpath = at(&format!("{JOURNAL_PREFIX}{}", self.id));
        write_synced(&jtmp, &text).map_err(|e| TrainerError::io(&jtmp, e))?;
        std::fs::rename(&jtmp, &jpath).map_err(|e| TrainerError::io(&jpath, e))?;
        self.sync_dir();
        // 4. Replace.
        for (k, e) in entries.iter().enumerate() {
            let _ = k; // the failure injection of the tests
            #[cfg(test)]
            if tests::fail_rename_at() == Some(k) {
                let err = std::io::Error::other("injected rename failure");
                return Err(self.roll_back_after(&jpath, &journal, &e.target, err));
            }
            if let Err(err) = std::fs::rename(at(&e.tmp), at(&e.target)) {
                return Err(self.roll_back_after(&jpath, &journal, &e.target, err));
            }
        }
        // 5. Finish.
        self.sync_dir();
        std::fs::remove_file(&jpath).map_err(|e| TrainerError::io(&jpath, e))?;
        for e in entries.iter() {
            if let Some(b) = &e.backup {
                let _ = std::fs::remove_file(at(b));
            }
        }
        Ok(())
    }

    /// A rename failed after the commit point: decide to go back, then put the old set back.
    fn roll_back_after(&self, jpath: &Path, journal: &Journal, target: &str, err: std::io::Error) -> TrainerError {
        let fail = TrainerError::io(&self.dir.join(target), clean_io(err));
        let rpath = self.dir.join(format!("{ROLLBACK_PREFIX}{}", self.id));
        if std::fs::rename(jpath, &rpath).is_err() {
            // The journal stays a forward journal: the next run rolls forward.
            return fail;
        }
        self.sync_dir();
        if roll_back(&self.dir, journal).is_ok() {
            self.sync_dir();
            let _ = std::fs::remove_file(&rpath);
        }
        fail
    }

    fn sync_dir(&self) {
        if let Some(f) = &self.lock {
            let _ = f.sync_all();
        }
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        if let Ok(s) = self.staged.get_mut() {
            for e in s.iter() {
                let _ = std::fs::remove_file(self.dir.join(&e.tmp));
            }
        }
    }
}

fn internal(p: &Path) -> TrainerError {
    TrainerError::Output { path: p.to_path_buf(), message: "internal: output set lock poisoned".into() }
}

fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = OpenOptions::new().write(true).create_new(true).open(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// A hard link to the old target; a copy where the file system has none. A target that
/// cannot be linked nor copied, or is immutable, fails here, before anything is replaced.
fn backup_file(target: &Path, backup: &Path) -> Result<(), TrainerError> {
    let fail = |e: std::io::Error| TrainerError::Output {
        path: target.to_path_buf(),
        message: format!("the old file cannot be kept aside until the new set is complete: {}", clean_io(e)),
    };
    let link = std::fs::hard_link(target, backup);
    let Err(link_err) = link else { return Ok(()) };
    // Immutable or append-only: a rename over it would fail later, so fail now.
    if is_immutable(target) {
        return Err(fail(link_err));
    }
    let meta = std::fs::symlink_metadata(target).map_err(fail)?;
    if meta.file_type().is_symlink() {
        let to = std::fs::read_link(target).map_err(fail)?;
        #[cfg(unix)]
        return std::os::unix::fs::symlink(to, backup).map_err(fail);
        #[cfg(not(unix))]
        return Err(fail(std::io::Error::other(format!("a symbolic link to {}", to.display()))));
    }
    std::fs::copy(target, backup).map_err(fail)?;
    File::open(backup).and_then(|f| f.sync_all()).map_err(fail)?;
    Ok(())
}

/// True when `path` refuses to be opened for writing, as an immutable or append-only file does
/// (even for root); such a file cannot be renamed over either.
fn is_immutable(path: &Path) -> bool {
    match OpenOptions::new().write(true).open(path) {
        Ok(_) => false,
        Err(e) => e.kind() == std::io::ErrorKind::PermissionDenied,
    }
}

/// Put the old set of `journal` back: a target whose temporary is gone was replaced, so it
/// gets its backup back (or is removed when it had no old file).
fn roll_back(dir: &Path, journal: &Journal) -> std::io::Result<()> {
    let mut result = Ok(());
    for e in &journal.entries {
        let (tmp, target) = (dir.join(&e.tmp), dir.join(&e.target));
        let replaced = std::fs::symlink_metadata(&tmp).is_err();
        if replaced {
            let r = match &e.backup {
                Some(b) => match std::fs::rename(dir.join(b), &target) {
                    Err(err) if err.kind() == std::io::ErrorKind::NotFound => Ok(()),
                    r => r,
                },
                None => match std::fs::remove_file(&target) {
                    Err(err) if err.kind() == std::io::ErrorKind::NotFound => Ok(()),
                    r => r,
                },
            };
            if r.is_err() {
                result = r;
                continue;
            }
        }
        let _ = std::fs::remove_file(&tmp);
        if let Some(b) = &e.backup {
            let _ = std::fs::remove_file(dir.join(b));
        }
    }
    result
}

/// Roll a committed journal forward: rename every temporary still there into place.
fn roll_forward(dir: &Path, journal: &Journal) -> std::io::Result<()> {
    for e in &journal.entries {
        let tmp = dir.join(&e.tmp);
        if std::fs::symlink_metadata(&tmp).is_ok() {
            std::fs::rename(&tmp, dir.join(&e.target))?;
        }
    }
    Ok(())
}

/// A name a journal may use: a plain file name (no separator, not `.` or `..`).
fn plain(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && !name.contains('/') && !name.contains('\\')
}

fn read_journal(path: &Path) -> Option<Journal> {
    let j: Journal = serde_json::from_slice(&std::fs::read(path).ok()?).ok()?;
    let ok = j.format == JOURNAL_FORMAT
        && j.entries.iter().all(|e| {
            plain(&e.target)
                && e.tmp.starts_with(TMP_PREFIX)
                && plain(&e.tmp)
                && e.backup.as_deref().is_none_or(|b| b.starts_with(TMP_PREFIX) && plain(b))
        });
    ok.then_some(j)
}

/// Finish what a killed run left in `dir` (module doc), when no other process is writing
/// there; returns without doing anything otherwise.
pub fn recover(dir: &Path) -> Result<(), TrainerError> {
    match File::open(dir) {
        Ok(f) if f.try_lock().is_ok() => recover_locked(dir),
        _ => Ok(()),
    }
}

/// [`recover`], once per directory and process: commands call it (through
/// [`prepare_output_dir`](super::prepare_output_dir) and [`OutputSet::in_dir`]) before their
/// work.
pub fn recover_once(dir: &Path) -> Result<(), TrainerError> {
    match File::open(dir) {
        Ok(f) => recover_with(&f, dir),
        Err(_) => Ok(()),
    }
}

/// [`recover_once`] through the open directory `f`; leaves `f` exclusively locked when it
/// recovered (the caller converts or drops the lock).
fn recover_with(f: &File, dir: &Path) -> Result<(), TrainerError> {
    let key = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    let done = recovered().lock().map(|s| s.contains(&key)).unwrap_or(false);
    if done || f.try_lock().is_err() {
        return Ok(());
    }
    recover_locked(dir)?;
    if let Ok(mut s) = recovered().lock() {
        s.insert(key);
    }
    Ok(())
}

/// [`recover`] with the directory's exclusive lock held.
fn recover_locked(dir: &Path) -> Result<(), TrainerError> {
    let Ok(list) = std::fs::read_dir(dir) else { return Ok(()) };
    let names: Vec<OsString> = list.filter_map(|e| e.ok().map(|e| e.file_name())).collect();
    let starts = |n: &OsString, p: &str| n.to_str().is_some_and(|s| s.starts_with(p));
    let mut journals: Vec<(&OsString, bool)> = names
        .iter()
        .filter_map(|n| {
            if starts(n, JOURNAL_PREFIX) {
                Some((n, true))
            } else if starts(n, ROLLBACK_PREFIX) {
                Some((n, false))
            } else {
                None
            }
        })
        .collect();
    journals.sort();
    for (name, forward) in journals {
        let path = dir.join(name);
        if let Some(j) = read_journal(&path) {
            if forward && roll_forward(dir, &j).is_err() {
                // It cannot go forward: decide to go back, as the live commit does.
                let back = dir.join(name.to_string_lossy().replacen(JOURNAL_PREFIX, ROLLBACK_PREFIX, 1));
                std::fs::rename(&path, &back).map_err(|e| TrainerError::io(&path, e))?;
                sync(dir);
                roll_back(dir, &j).map_err(|e| TrainerError::io(dir, e))?;
                sync(dir);
                std::fs::remove_file(&back).map_err(|e| TrainerError::io(&back, e))?;
                continue;
            }
            if !forward {
                roll_back(dir, &j).map_err(|e| TrainerError::io(dir, e))?;
            }
            sync(dir);
        }
        std::fs::remove_file(&path).map_err(|e| TrainerError::io(&path, e))?;
    }
    for n in names.iter().filter(|n| starts(n, TMP_PREFIX)) {
        let p = dir.join(n);
        if std::fs::symlink_metadata(&p).is_ok_and(|m| !m.is_dir()) {
            let _ = std::fs::remove_file(&p);
        }
    }
    Ok(())
}

fn sync(dir: &Path) {
    if let Ok(f) = File::open(dir) {
        let _ = f.sync_all();
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::cell::Cell;

    thread_local! {
        static FAIL_AT: Cell<Option<usize>> = const { Cell::new(None) };
    }

    pub(crate) fn fail_rename_at() -> Option<usize> {
        FAIL_AT.with(|c| c.get())
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    fn old_set(dir: &Path) {
        for (n, b) in [("a", "old a"), ("b", "old b"), ("c", "old c")] {
            std::fs::write(dir.join(n), b).unwrap();
        }
    }

    fn read(dir: &Path, n: &str) -> String {
        std::fs::read_to_string(dir.join(n)).unwrap_or_else(|_| "<none>".into())
    }

    fn stage_new(dir: &Path) -> OutputSet {
        let s = OutputSet::in_dir(dir).unwrap();
        for n in ["a", "b", "c", "d"] {
            s.stage_bytes(&dir.join(n), format!("new {n}").as_bytes()).unwrap();
        }
        s
    }

    #[test]
    fn a_committed_set_replaces_every_file_and_leaves_no_temporaries() {
        let d = tempfile::tempdir().unwrap();
        old_set(d.path());
        stage_new(d.path()).commit().unwrap();
        for n in ["a", "b", "c", "d"] {
            assert_eq!(read(d.path(), n), format!("new {n}"));
        }
        assert_eq!(names(d.path()), ["a", "b", "c", "d"]);
    }

    #[test]
    fn a_set_dropped_before_its_commit_changes_nothing() {
        let d = tempfile::tempdir().unwrap();
        old_set(d.path());
        drop(stage_new(d.path()));
        assert_eq!(names(d.path()), ["a", "b", "c"]);
        assert_eq!(read(d.path(), "b"), "old b");
    }

    #[test]
    fn a_rename_failing_after_the_commit_point_puts_the_old_set_back() {
        let d = tempfile::tempdir().unwrap();
        for k in 0..4 {
            old_set(d.path());
            let _ = std::fs::remove_file(d.path().join("d"));
            FAIL_AT.with(|c| c.set(Some(k)));
            let r = stage_new(d.path()).commit();
            FAIL_AT.with(|c| c.set(None));
            assert!(r.is_err(), "rename {k}");
            assert_eq!(names(d.path()), ["a", "b", "c"], "after a failure at rename {k}");
            for n in ["a", "b", "c"] {
                assert_eq!(read(d.path(), n), format!("old {n}"), "rename {k}");
            }
        }
    }

    #[test]
    fn a_directory_standing_at_a_target_fails_before_anything_is_replaced() {
        let d = tempfile::tempdir().unwrap();
        old_set(d.path());
        let s = OutputSet::in_dir(d.path()).unwrap();
        for n in ["a", "b"] {
            s.stage_bytes(&d.path().join(n), b"new").unwrap();
        }
        // A directory at a target is refused when staged...
        std::fs::create_dir(d.path().join("e")).unwrap();
        assert!(s.stage_bytes(&d.path().join("e"), b"new").is_err());
        std::fs::remove_dir(d.path().join("e")).unwrap();
        // ...and when it appears after staging, by the commit's own check.
        s.stage_bytes(&d.path().join("e"), b"new").unwrap();
        std::fs::create_dir(d.path().join("e")).unwrap();
        let e = s.commit().unwrap_err().to_string();
        assert!(e.contains("directory"), "{e}");
        assert_eq!(read(d.path(), "a"), "old a");
        assert_eq!(read(d.path(), "b"), "old b");
        assert_eq!(names(d.path()), ["a", "b", "c", "e"]);
    }

    /// Every state a kill can leave (a journal with some renames done, a rollback journal
    /// halfway back) is finished by the next set in the directory into a whole set.
    #[test]
    fn recovery_rolls_a_journal_forward_and_a_rollback_journal_back() {
        for done in 0..=3 {
            for forward in [true, false] {
                let d = tempfile::tempdir().unwrap();
                let dir = d.path();
                old_set(dir);
                let entries: Vec<Entry> = ["a", "b", "c"]
                    .iter()
                    .enumerate()
                    .map(|(k, n)| {
                        let tmp = format!("{TMP_PREFIX}x-{k}");
                        std::fs::write(dir.join(&tmp), format!("new {n}")).unwrap();
                        let backup = format!("{tmp}.old");
                        std::fs::hard_link(dir.join(n), dir.join(&backup)).unwrap();
                        Entry { target: n.to_string(), tmp, backup: Some(backup) }
                    })
                    .collect();
                for e in entries.iter().take(done) {
                    std::fs::rename(dir.join(&e.tmp), dir.join(&e.target)).unwrap();
                }
                let j = Journal { format: JOURNAL_FORMAT.into(), entries };
                let prefix = if forward { JOURNAL_PREFIX } else { ROLLBACK_PREFIX };
                std::fs::write(dir.join(format!("{prefix}x")), serde_json::to_vec(&j).unwrap()).unwrap();
                std::fs::write(dir.join(format!("{TMP_PREFIX}stale")), "litter").unwrap();
                recover(dir).unwrap();
                assert_eq!(names(dir), ["a", "b", "c"], "done {done}, forward {forward}");
                let want = if forward { "new" } else { "old" };
                for n in ["a", "b", "c"] {
                    assert_eq!(read(dir, n), format!("{want} {n}"), "done {done}, forward {forward}");
                }
            }
        }
    }

    #[test]
    fn a_journal_naming_a_path_outside_the_directory_is_ignored() {
        let d = tempfile::tempdir().unwrap();
        let j = Journal {
            format: JOURNAL_FORMAT.into(),
            entries: vec![Entry { target: "../escape".into(), tmp: format!("{TMP_PREFIX}x-0"), backup: None }],
        };
        std::fs::write(d.path().join(format!("{TMP_PREFIX}x-0")), "x").unwrap();
        std::fs::write(d.path().join(format!("{JOURNAL_PREFIX}x")), serde_json::to_vec(&j).unwrap()).unwrap();
        recover(d.path()).unwrap();
        assert!(names(d.path()).is_empty());
        assert!(!d.path().parent().unwrap().join("escape").exists());
    }

    #[test]
    fn recovery_leaves_a_live_writers_temporaries_alone() {
        let d = tempfile::tempdir().unwrap();
        let live = OutputSet::in_dir(d.path()).unwrap();
        live.stage_bytes(&d.path().join("a"), b"x").unwrap();
        recover(d.path()).unwrap();
        assert_eq!(names(d.path()).len(), 1, "the live temporary is kept");
        live.commit().unwrap();
        assert_eq!(names(d.path()), ["a"]);
    }
}
