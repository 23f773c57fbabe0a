//! Writing outputs safely (DESIGN §9): atomically through a temporary file in the same
//! directory, several files of a command as one set ([`set`]), never over a device, FIFO,
//! socket or directory, never over an input or another output of the same command (one
//! check, [`check_outputs`], on canonical paths and inodes), into directories created and
//! checked before any work.

pub mod set;

use std::collections::HashMap;
use std::io::Write;
use std::path::{Component, Path, PathBuf};

pub use set::OutputSet;

use crate::error::TrainerError;

/// Write `path` through a temporary file in the same directory and rename it into place, so
/// that a failure never leaves a half-written file (a one-file [`OutputSet`], which also
/// clears what a killed run left in that directory).
pub(crate) fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<(), TrainerError> {
    refuse_non_regular(path)?;
    let set = OutputSet::beside(path)?;
    set.stage(path, body)?;
    set.commit()
}

/// An output that exists and is not a regular file (a device such as `/dev/null`, a FIFO, a
/// socket, a directory) is refused, never renamed over (DESIGN §9). A symbolic link is judged
/// by what it points to.
pub(crate) fn refuse_non_regular(path: &Path) -> Result<(), TrainerError> {
    let Ok(m) = std::fs::metadata(path) else { return Ok(()) };
    if m.is_file() {
        return Ok(());
    }
    let what = if m.is_dir() { "a directory" } else { "not a regular file (a device, FIFO or socket)" };
    Err(TrainerError::Output {
        path: path.to_path_buf(),
        message: format!("the output exists and is {what}; refusing to replace it (choose a file name)"),
    })
}

/// Check the outputs of a command before any work is done (DESIGN §9): none may exist as
/// something other than a regular file, none may be one of the inputs or another output (the
/// same file by canonical path, or by device and inode, so a hard link, a symbolic link or
/// another spelling of the path counts too); then their directories are created when missing
/// and checked for writing. O(n log n) in the number of paths.
pub fn check_outputs(outputs: &[&Path], inputs: &[&Path]) -> Result<(), TrainerError> {
    for o in outputs {
        refuse_non_regular(o)?;
    }
    let mut r = Resolver::default();
    let outs: Vec<Resolved> = outputs.iter().map(|p| r.resolve(p)).collect();
    let ins: Vec<Resolved> = inputs.iter().map(|p| r.resolve(p)).collect();
    if let Some((k, clash)) = first_clash(&outs, &ins) {
        let o = outputs[k];
        let message = match clash {
            Clash::Input(j) => {
                let i = inputs[j];
                let also = if i.as_os_str() == o.as_os_str() { String::new() } else { format!(" ({})", i.display()) };
                format!("the output is also an input{also}; refusing to overwrite it (choose another output name)")
            }
            Clash::Output(j) => format!(
                "the output is also another output of this command ({}); refusing to write one file twice (choose distinct names)",
                outputs[j].display()
            ),
        };
        return Err(TrainerError::Output { path: o.to_path_buf(), message });
    }
    prepare_output_dirs(outputs)
}

/// A file's identity: device and inode (a hard link or a symbolic link to a file has its
/// target's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct FileId {
    dev: u64,
    ino: u64,
}

impl FileId {
    /// The identity of the file `path` names (following symbolic links), when it exists.
    pub fn of(path: &Path) -> Option<FileId> {
        let m = std::fs::metadata(path).ok()?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Some(FileId { dev: m.dev(), ino: m.ino() })
        }
        #[cfg(not(unix))]
        {
            let _ = m;
            None
        }
    }
}

/// A path resolved for comparison: canonical (the existing part with symbolic links resolved,
/// the rest appended with `.` and `..` taken lexically) and, when it exists, its identity.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Resolved {
    pub canonical: PathBuf,
    pub id: Option<FileId>,
}

/// Resolves paths, remembering the directories it resolved (the outputs of a fleet share a
/// few directories, so each is canonicalised once).
#[derive(Default)]
pub(crate) struct Resolver {
    dirs: HashMap<PathBuf, PathBuf>,
}

impl Resolver {
    /// Resolve `path` (see [`Resolved`]).
    pub fn resolve(&mut self, path: &Path) -> Resolved {
        if let Ok(c) = path.canonicalize() {
            return Resolved { canonical: c, id: FileId::of(path) };
        }
        match (path.parent(), path.file_name()) {
            (Some(parent), Some(name)) => Resolved { canonical: self.dir(parent).join(name), id: None },
            _ => Resolved { canonical: self.dir(path), id: None },
        }
    }

    fn dir(&mut self, dir: &Path) -> PathBuf {
        if let Some(c) = self.dirs.get(dir) {
            return c.clone();
        }
        let c = if dir.as_os_str().is_empty() {
            std::env::current_dir().unwrap_or_default()
        } else if let Ok(c) = dir.canonicalize() {
            c
        } else {
            // Missing: its parent resolved, then its last component taken lexically (a
            // missing directory is no symbolic link).
            let mut base = self.dir(dir.parent().unwrap_or(Path::new("")));
            match dir.components().next_back() {
                Some(Component::ParentDir) => {
                    base.pop();
                }
                Some(Component::Normal(n)) => base.push(n),
                Some(Component::RootDir) | Some(Component::Prefix(_)) => base = dir.to_path_buf(),
                Some(Component::CurDir) | None => {}
            }
            base
        };
        self.dirs.insert(dir.to_path_buf(), c.clone());
        c
    }
}

/// What an output clashes with: the input or the earlier output of that index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Clash {
    Input(usize),
    Output(usize),
}

/// The first output that is the same file as an input or an earlier output (by canonical path
/// or by identity), and what it clashes with; hashing, so linear in the number of paths.
pub(crate) fn first_clash(outputs: &[Resolved], inputs: &[Resolved]) -> Option<(usize, Clash)> {
    let mut paths: HashMap<&Path, Clash> = HashMap::with_capacity(outputs.len() + inputs.len());
    let mut ids: HashMap<FileId, Clash> = HashMap::new();
    for (j, i) in inputs.iter().enumerate() {
        paths.entry(&i.canonical).or_insert(Clash::Input(j));
        if let Some(id) = i.id {
            ids.entry(id).or_insert(Clash::Input(j));
        }
    }
    for (k, o) in outputs.iter().enumerate() {
        let seen = paths.get(o.canonical.as_path()).or_else(|| o.id.and_then(|id| ids.get(&id)));
        if let Some(&c) = seen {
            return Some((k, c));
        }
        paths.insert(&o.canonical, Clash::Output(k));
        if let Some(id) = o.id {
            ids.insert(id, Clash::Output(k));
        }
    }
    None
}

/// Create the directory of every output (as `fleet` does) and check that it can be written,
/// before any work: one message naming the directory, never a temporary file's name.
pub(crate) fn prepare_output_dirs(outputs: &[&Path]) -> Result<(), TrainerError> {
    for o in outputs {
        match o.parent() {
            Some(p) if !p.as_os_str().is_empty() => prepare_output_dir(p)?,
            _ => prepare_output_dir(Path::new("."))?,
        }
    }
    Ok(())
}

/// Create `dir` (and its parents) when missing, recover what a killed run left in it
/// ([`set::recover_once`]) and check that a file can be created in it.
pub fn prepare_output_dir(dir: &Path) -> Result<(), TrainerError> {
    let fail = |what: &str, e: std::io::Error| TrainerError::Output {
        path: dir.to_path_buf(),
        message: format!("{what}: {}", clean_io(e)),
    };
    if dir.exists() && !dir.is_dir() {
        return Err(TrainerError::Output {
            path: dir.to_path_buf(),
            message: "the output directory exists and is not a directory".into(),
        });
    }
    std::fs::create_dir_all(dir).map_err(|e| fail("cannot create the output directory", e))?;
    // What a killed run left here is finished before this run's work.
    set::recover_once(dir)?;
    tempfile::Builder::new()
        .prefix(".fbg-tmp-")
        .tempfile_in(dir)
        .map_err(|e| fail("the output directory is not writable", e))?;
    Ok(())
}

/// An I/O error without tempfile's `at path ".fbg-tmp-…"` suffix, which names a file the user
/// never asked for.
pub(crate) fn clean_io(e: std::io::Error) -> std::io::Error {
    let text = e.to_string();
    match text.find(" at path ") {
        Some(k) => std::io::Error::new(e.kind(), text[..k].to_string()),
        None => e,
    }
}

/// Write bytes atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), TrainerError> {
    write_atomically(path, |w| w.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_paths_resolve_through_their_existing_directory() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path();
        let mut r = Resolver::default();
        let plain = r.resolve(&p.join("m.fbgm"));
        // `sub` does not exist: `sub/..` is taken lexically.
        assert_eq!(r.resolve(&p.join("sub/../m.fbgm")), plain);
        assert_eq!(r.resolve(&p.join("a/b/../../m.fbgm")), plain);
        assert_eq!(plain.canonical, p.canonicalize().unwrap().join("m.fbgm"));
        assert_eq!(plain.id, None);
    }

    #[test]
    fn an_output_given_twice_is_refused_naming_both() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("m.fbgm"), d.path().join("x/../m.fbgm"));
        let e = check_outputs(&[&a, &b], &[]).unwrap_err().to_string();
        assert!(e.contains("another output") && e.contains("x/../m.fbgm"), "{e}");
        assert!(check_outputs(&[&a, &d.path().join("n.fbgm")], &[]).is_ok());
    }
}
