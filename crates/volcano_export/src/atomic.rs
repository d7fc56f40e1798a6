//! Files written whole or not at all: into a temporary file in the destination's folder
//! (`tempfile`), renamed over the destination once the writer returned `Ok` and the data
//! reached the disk. On an error the temporary file is removed.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// Creating, flushing or renaming the file failed: nothing was left at `path`. Each format's
/// error type converts it into its own variant.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct FileError {
    /// The file.
    pub path: String,
    /// Why.
    pub source: std::io::Error,
}

/// Runs `write` on a buffered temporary file beside `path` and renames it to `path` if it
/// succeeds.
pub fn write_atomically<E>(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), E>,
) -> Result<(), E>
where
    E: From<FileError>,
{
    let file_error = |source: std::io::Error| FileError { path: path.display().to_string(), source };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".volcano-").suffix(".part");
    // A temporary file is private (0600) by default; the finished file is an ordinary one
    // (0666 less the process's umask, as `File::create` makes).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let tmp = builder.tempfile_in(dir).map_err(file_error)?;
    let (file, tmp_path) = tmp.into_parts();
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    let file = w.into_inner().map_err(|e| file_error(e.into_error()))?;
    file.sync_all().map_err(file_error)?;
    tmp_path.persist(path).map_err(|e| file_error(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vdb::VdbError;
    use std::io::Write;

    #[test]
    fn an_error_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.vdb");
        let r: Result<(), VdbError> = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(VdbError::Format("refused".into()))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "no file, no temporary");
        write_atomically::<VdbError>(&path, |w| Ok(w.write_all(b"whole")?)).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"whole");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o044, 0o044 & !umask(), "readable by others as a created file: {mode:o}");
        }
    }

    /// The process's umask, read back from a file `File::create` makes.
    #[cfg(unix)]
    fn umask() -> u32 {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("probe");
        std::fs::File::create(&p).unwrap();
        !std::fs::metadata(&p).unwrap().permissions().mode() & 0o777
    }

    #[test]
    fn an_unwritable_folder_is_an_error_naming_the_file() {
        let path = Path::new("/nonexistent-volcano-dir/x.vdb");
        let e = write_atomically::<VdbError>(path, |_| Ok(())).unwrap_err();
        assert!(e.to_string().contains("/nonexistent-volcano-dir/x.vdb"), "{e}");
    }
}
