//! Whole-or-nothing file writes: write a temporary file next to the target,
//! flush and fsync it, then rename it over the target.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Removes the temporary file when dropped, unless disarmed after the rename.
struct TempGuard {
    path: PathBuf,
    armed: bool,
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if self.armed {
            // Best effort: the file may already be gone.
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The temporary path used for `path`: `.NAME.tmp-PID` in the same directory.
pub fn temp_path_for(path: &Path) -> Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| Error::Output {
        path: path.to_path_buf(),
        what: "the path does not name a file".to_owned(),
    })?;
    let tmp_name = format!(".{}.tmp-{}", name.to_string_lossy(), std::process::id());
    Ok(parent_dir(path).join(tmp_name))
}

/// The directory `path` lives in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `path` whole or not at all.
///
/// `write` fills a buffered temporary file `.NAME.tmp-PID` in the same
/// directory; it is then flushed, fsynced and renamed over `path`. On any
/// error (including one returned by `write`) the temporary file is removed
/// and `path` is left as it was.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(Error::Output {
            path: path.to_path_buf(),
            what: format!("the directory {} does not exist", dir.display()),
        });
    }
    let tmp = temp_path_for(path)?;
    let file = OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&tmp)
        .map_err(|e| Error::Output {
            path: path.to_path_buf(),
            what: format!("cannot create temporary file {}: {e}", tmp.display()),
        })?;
    let mut guard = TempGuard {
        path: tmp.clone(),
        armed: true,
    };

    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    writer.flush().map_err(|e| Error::io(&tmp, e))?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(&tmp, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(&tmp, e))?;
    drop(file);

    std::fs::rename(&tmp, path).map_err(|e| Error::Output {
        path: path.to_path_buf(),
        what: format!("cannot rename {} into place: {e}", tmp.display()),
    })?;
    guard.armed = false;

    // Make the rename itself durable where the platform allows it.
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vkrad-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_whole_file_and_leaves_no_temp() {
        let dir = scratch_dir("ok");
        let path = dir.join("out.txt");
        write_atomically(&path, |w| {
            w.write_all(b"hello").map_err(|e| Error::io("out.txt", e))
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");
        assert_eq!(entries(&dir), vec!["out.txt".to_owned()]);
        // Overwrite replaces the content.
        write_atomically(&path, |w| {
            w.write_all(b"bye").map_err(|e| Error::io("out.txt", e))
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"bye");
        assert_eq!(entries(&dir), vec!["out.txt".to_owned()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failing_closure_leaves_nothing() {
        let dir = scratch_dir("fail");
        let path = dir.join("out.txt");
        let err = write_atomically(&path, |w| {
            w.write_all(b"partial").unwrap();
            Err(Error::Invalid("boom".into()))
        })
        .unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        assert!(!path.exists());
        assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failing_closure_keeps_old_file() {
        let dir = scratch_dir("keep");
        let path = dir.join("out.txt");
        std::fs::write(&path, b"old").unwrap();
        let _ = write_atomically(&path, |w| {
            w.write_all(b"new").unwrap();
            Err(Error::Invalid("boom".into()))
        });
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(&dir), vec!["out.txt".to_owned()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_directory_errors_naming_path() {
        let dir = scratch_dir("missing");
        let path = dir.join("no/such/dir/out.txt");
        let err = write_atomically(&path, |_| Ok(())).unwrap_err();
        match &err {
            Error::Output { path: p, .. } | Error::Io { path: p, .. } => assert_eq!(p, &path),
            other => panic!("unexpected error {other:?}"),
        }
        assert!(err.to_string().contains("out.txt"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn rename_onto_directory_errors_and_cleans_up() {
        let dir = scratch_dir("ontodir");
        let path = dir.join("sub");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("x"), b"x").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"data").map_err(|e| Error::io("sub", e))
        })
        .unwrap_err();
        assert!(matches!(err, Error::Output { .. }), "{err:?}");
        assert_eq!(entries(&dir), vec!["sub".to_owned()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temp_name_format() {
        let t = temp_path_for(Path::new("a/b.png")).unwrap();
        assert_eq!(
            t,
            Path::new("a").join(format!(".b.png.tmp-{}", std::process::id()))
        );
        let t = temp_path_for(Path::new("b.png")).unwrap();
        assert_eq!(t.parent(), Some(Path::new(".")));
    }
}
