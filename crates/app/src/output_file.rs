//! Output files replaced whole: each is written to a temporary file beside its target (the
//! `tempfile` crate's, created exclusively) and moved over the target only once complete and on
//! disk, so a failed or interrupted write leaves the old file as it was.

use std::io;
use std::path::Path;

use tempfile::{NamedTempFile, TempPath};

/// A new temporary file beside `target`, `NAME.partial.PID.RANDOM`: created exclusively (never an
/// existing file or a symlink), with the permissions a new file gets (0666 less the umask), and
/// removed when dropped before [`persist`].
pub fn temp_beside(target: &Path) -> io::Result<NamedTempFile> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut prefix = target.file_name().unwrap_or_default().to_os_string();
    prefix.push(format!(".partial.{}.", std::process::id()));
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).rand_bytes(8);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir)
}

/// Moves the complete `temp` onto `target`: its data synced to disk, then renamed over the
/// target in one step. On an error the temporary file is removed.
pub fn persist(temp: NamedTempFile, target: &Path) -> io::Result<()> {
    temp.as_file().sync_all()?;
    temp.persist(target).map(drop).map_err(|e| e.error)
}

/// [`persist`] for a temporary file written through its path (by a writer that opens it itself).
pub fn persist_path(temp: TempPath, target: &Path) -> io::Result<()> {
    std::fs::File::open(&temp)?.sync_all()?;
    temp.persist(target).map_err(|e| e.error)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn a_temporary_file_beside_its_target_replaces_it_whole() {
        let dir = std::env::temp_dir().join(format!("arcsim-app-output-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let target = dir.join("out.json");
        std::fs::write(&target, "old").expect("old file");
        let mut temp = temp_beside(&target).expect("temporary file");
        assert_eq!(temp.path().parent(), Some(dir.as_path()));
        let name = temp.path().file_name().expect("name").to_string_lossy();
        let prefix = format!("out.json.partial.{}.", std::process::id());
        assert!(name.starts_with(&prefix), "{name}");
        assert_eq!(name.len(), prefix.len() + 8, "{name}");
        // The permissions a new file gets, not a temporary file's 0600.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let plain = dir.join("plain");
            std::fs::write(&plain, "").expect("plain file");
            let mode = |p: &Path| std::fs::metadata(p).expect("metadata").permissions().mode();
            assert_eq!(mode(temp.path()), mode(&plain));
            std::fs::remove_file(plain).expect("removed");
        }
        temp.write_all(b"new").expect("written");
        assert_eq!(std::fs::read_to_string(&target).expect("read"), "old");
        persist(temp, &target).expect("persisted");
        assert_eq!(std::fs::read_to_string(&target).expect("read"), "new");
        // Dropped before it is persisted: removed, the target untouched.
        let temp = temp_beside(&target).expect("temporary file");
        let path = temp.path().to_path_buf();
        drop(temp);
        assert!(!path.exists());
        // Written through its path by another writer.
        let temp = temp_beside(&target)
            .expect("temporary file")
            .into_temp_path();
        std::fs::write(&temp, "through the path").expect("written");
        persist_path(temp, &target).expect("persisted");
        assert_eq!(
            std::fs::read_to_string(&target).expect("read"),
            "through the path"
        );
        let left: Vec<_> = std::fs::read_dir(&dir).expect("dir").flatten().collect();
        assert_eq!(left.len(), 1, "only the target is left: {left:?}");
        // A target in a directory that does not exist: the error says so.
        assert!(temp_beside(&dir.join("missing/out.json")).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
