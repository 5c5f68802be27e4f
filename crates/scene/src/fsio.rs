//! File-system helpers shared by every writer: no partial output, no silent
//! overwrite.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::error::{Location, Result, SceneError};

/// Refuses to go on when `path` exists and `force` is false.
pub fn check_overwrite(path: &Path, force: bool) -> Result<()> {
    if !force && path.exists() {
        return Err(SceneError::AlreadyExists {
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

/// A file the user named as an output: [`check_parent_exists`], then
/// [`check_overwrite`]. (Library writers that create their own subfolders
/// inside an output call [`check_overwrite`] alone.)
pub fn check_output_file(path: &Path, force: bool) -> Result<()> {
    check_parent_exists(path)?;
    check_overwrite(path, force)
}

/// The one rule for outputs in missing folders, for every file and folder
/// vpctl writes: refused before any work, naming the missing folder and the
/// `mkdir -p` that fixes it. vpctl creates the output it is asked for but
/// never the folders above it, as gdal and COLMAP do not: a typo in a
/// parent (`/mnt/usbb/run1`) would otherwise write a new tree somewhere the
/// operator does not look, or onto the wrong disk.
pub fn check_parent_exists(path: &Path) -> Result<()> {
    let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) else {
        return Ok(());
    };
    if dir.is_dir() {
        return Ok(());
    }
    let why = if dir.exists() {
        format!("{} is a file, not a folder", dir.display())
    } else {
        format!("the folder {} does not exist", dir.display())
    };
    let fix = if dir.exists() {
        "nothing was written; choose a path in a folder".to_string()
    } else {
        format!(
            "nothing was written; vpctl does not create the folders above an output: \
             create it first (`mkdir -p {}`) or choose another path",
            dir.display()
        )
    };
    Err(SceneError::OutputRefused {
        path: path.to_path_buf(),
        why,
        fix,
    })
}

/// Writes a file atomically: the content goes to a temporary file beside
/// `path`, which is renamed over `path` only when `write` succeeded. A failed
/// or interrupted write therefore never leaves a partial file behind.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file_name = path.file_name().ok_or_else(|| {
        SceneError::InvalidArgument(format!("{}: not a file path", path.display()))
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        file_name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        write(&mut w)?;
        w.flush()?;
        w.get_ref().sync_all()?;
        drop(w);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(SceneError::io(path, e));
    }
    Ok(())
}

/// [`write_atomic`] of a whole buffer.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Reads a whole file, naming it in the error.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| SceneError::io(path, e))
}

/// Reads a whole text file: UTF-8, with a leading byte-order mark (as some
/// Windows editors write) dropped. Invalid UTF-8 is an error naming the byte.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = read_file(path)?;
    let mut text = String::from_utf8(bytes).map_err(|e| {
        SceneError::parse(
            path,
            Location::Byte(e.utf8_error().valid_up_to() as u64),
            "not UTF-8 text",
        )
    })?;
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        let err = write_atomic(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(err.is_err());
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn existing_file_is_not_overwritten_without_force() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        std::fs::write(&path, "mine").unwrap();
        assert!(matches!(
            check_overwrite(&path, false),
            Err(SceneError::AlreadyExists { .. })
        ));
        assert!(check_overwrite(&path, true).is_ok());
    }
}
