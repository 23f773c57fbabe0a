//! Writing outputs safely (DESIGN §9): atomically through a temporary file in the same
//! directory, never over a device, FIFO, socket or directory, never over an input, into
//! directories created and checked before any work.

use std::io::Write;
use std::path::Path;

use crate::error::TrainerError;

/// Write `path` through a temporary file in the same directory and rename it into place, so
/// that a failure never leaves a half-written file.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<(), TrainerError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    refuse_non_regular(path)?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".fbg-tmp-")
        .tempfile_in(&dir)
        .map_err(|e| TrainerError::io(path, clean_io(e)))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        body(&mut w).map_err(|e| TrainerError::io(path, e))?;
        w.flush().map_err(|e| TrainerError::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| TrainerError::io(path, e))?;
    // tempfile creates 0600; an output file should be readable like any other.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o644))
            .map_err(|e| TrainerError::io(path, e))?;
    }
    // Checked again just before the rename: a rename would replace a device, FIFO or socket
    // that appeared meanwhile with a regular file.
    refuse_non_regular(path)?;
    tmp.persist(path).map_err(|e| TrainerError::io(path, clean_io(e.error)))?;
    Ok(())
}

/// An output that exists and is not a regular file (a device such as `/dev/null`, a FIFO, a
/// socket, a directory) is refused, never renamed over (DESIGN §9). A symbolic link is judged
/// by what it points to.
pub fn refuse_non_regular(path: &Path) -> Result<(), TrainerError> {
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
/// something other than a regular file, and none may be one of the inputs (the same file by
/// device and inode, so a hard link or another spelling of the path counts too); then their
/// directories are created when missing and checked for writing.
pub fn check_outputs(outputs: &[&Path], inputs: &[&Path]) -> Result<(), TrainerError> {
    for o in outputs {
        refuse_non_regular(o)?;
        if let Some(i) = inputs.iter().find(|i| same_file(o, i)) {
            let also = if i.as_os_str() == o.as_os_str() { String::new() } else { format!(" ({})", i.display()) };
            return Err(TrainerError::Output {
                path: o.to_path_buf(),
                message: format!(
                    "the output is also an input{also}; refusing to overwrite it (choose another output name)"
                ),
            });
        }
    }
    prepare_output_dirs(outputs)
}

/// Create the directory of every output (as `fleet` does) and check that it can be written,
/// before any work: one message naming the directory, never a temporary file's name.
pub fn prepare_output_dirs(outputs: &[&Path]) -> Result<(), TrainerError> {
    for o in outputs {
        match o.parent() {
            Some(p) if !p.as_os_str().is_empty() => prepare_output_dir(p)?,
            _ => prepare_output_dir(Path::new("."))?,
        }
    }
    Ok(())
}

/// Create `dir` (and its parents) when missing and check that a file can be created in it.
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
    tempfile::Builder::new()
        .prefix(".fbg-tmp-")
        .tempfile_in(dir)
        .map_err(|e| fail("the output directory is not writable", e))?;
    Ok(())
}

/// An I/O error without tempfile's `at path ".fbg-tmp-…"` suffix, which names a file the user
/// never asked for.
fn clean_io(e: std::io::Error) -> std::io::Error {
    let text = e.to_string();
    match text.find(" at path ") {
        Some(k) => std::io::Error::new(e.kind(), text[..k].to_string()),
        None => e,
    }
}

/// True when both paths exist and name the same file.
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) else { return false };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        x.dev() == y.dev() && x.ino() == y.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (x, y);
        matches!((a.canonicalize(), b.canonicalize()), (Ok(p), Ok(q)) if p == q)
    }
}

/// Write bytes atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), TrainerError> {
    write_atomically(path, |w| w.write_all(bytes))
}
