//! Whole-or-nothing file writes: a temporary file next to the target
//! (`tempfile`: a unique name, removed when dropped on any error), flushed
//! and fsynced, then renamed over the target.
//!
//! The file gets the permissions any other tool's would: a new one those
//! the process's umask leaves of rw-rw-rw- (as `File::create`), one that
//! replaces a file the old file's (as `File::create`, which truncates it).
//! `tempfile` alone makes its files rw------- (private scratch files).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::error::{Error, Result};

/// The directory `path` lives in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `path` whole or not at all.
///
/// `write` fills a buffered temporary file `.NAME.XXXXXX.tmp` in the same
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
    let name = path.file_name().ok_or_else(|| Error::Output {
        path: path.to_path_buf(),
        what: "the path does not name a file".to_owned(),
    })?;
    let prefix = format!(".{}.", name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // Created rw-rw-rw- less the umask, as `File::create` does.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let tmp = builder.tempfile_in(dir).map_err(|e| Error::Output {
        path: path.to_path_buf(),
        what: format!("cannot create a temporary file in {}: {e}", dir.display()),
    })?;
    let tmp_path = tmp.path().to_path_buf();
    let (file, tmp_path_guard) = tmp.into_parts();
    // A file it replaces keeps its permissions.
    if let Ok(old) = std::fs::metadata(path) {
        if old.is_file() {
            file.set_permissions(old.permissions())
                .map_err(|e| Error::io(&tmp_path, e))?;
        }
    }
    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    writer.flush().map_err(|e| Error::io(&tmp_path, e))?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(&tmp_path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(&tmp_path, e))?;
    drop(file);
    tmp_path_guard.persist(path).map_err(|e| Error::Output {
        path: path.to_path_buf(),
        what: format!(
            "cannot rename {} into place: {}",
            tmp_path.display(),
            e.error
        ),
    })?;
    // Make the rename itself durable where the platform allows it.
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

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

    #[cfg(unix)]
    #[test]
    fn written_files_take_the_permissions_file_create_gives() {
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o7777;
        let dir = scratch_dir("mode");
        // What the umask makes of a new file, as other tools write it.
        let plain = dir.join("plain.txt");
        File::create(&plain).unwrap();
        let path = dir.join("out.txt");
        write_atomically(&path, |w| {
            w.write_all(b"x").map_err(|e| Error::io("out.txt", e))
        })
        .unwrap();
        assert_eq!(mode(&path), mode(&plain), "{:o}", mode(&path));
        // A file it replaces keeps its own.
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomically(&path, |w| {
            w.write_all(b"y").map_err(|e| Error::io("out.txt", e))
        })
        .unwrap();
        assert_eq!(mode(&path), 0o640);
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
}
