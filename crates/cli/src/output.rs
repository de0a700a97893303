//! Writing results. Standard output ends quietly when its reader goes away (`arcsim … | head`).
//!
//! Output files are checked before the work starts: no alias of an input or of another output
//! (compared after following symlinks), a directory that exists and takes a new file. A regular
//! file is written to a temporary file of its own beside its target
//! (`NAME.partial.PID.RANDOM`, created exclusively by the `tempfile` crate, so no other file is
//! ever opened or truncated; [`arcsim_app::output_file`]), synced to disk and renamed into place
//! only when complete: a failed or interrupted command leaves the old file as it was, and two
//! commands writing the same output each leave a complete file. An output that
//! is a symlink is written through it (the link stays, its target is replaced). Anything that is
//! not a regular file (a FIFO, a character device such as `/dev/null`) is written directly, and
//! `-` (or `/dev/stdout`) is standard output, where the command's own report then goes to
//! standard error.

use std::fs::OpenOptions;
use std::io::{BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use arcsim_app::output_file::{persist, persist_path, temp_beside};
use tempfile::NamedTempFile;

use crate::CliError;

/// Set when an output is standard output: [`print`] then writes to standard error, so the
/// command's report does not mix with the output.
static STDOUT_IS_AN_OUTPUT: AtomicBool = AtomicBool::new(false);

/// `text` with control characters other than line breaks and tabs shown as escapes (`\u{1b}`),
/// so a name in a file (a plan name with ANSI codes) cannot drive the terminal.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    let bad = |c: char| c.is_control() && c != '\n' && c != '\t';
    if !text.chars().any(bad) {
        return text.into();
    }
    text.chars()
        .map(|c| {
            if bad(c) {
                c.escape_unicode().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// Writes `text` to standard output (standard error when standard output is one of the
/// command's outputs), control characters escaped ([`printable`]). A closed pipe ends the
/// process quietly with exit 0, as Unix tools do when their reader has all it wanted; other
/// write errors are reported.
pub fn print(text: &str) {
    let text = printable(text);
    if STDOUT_IS_AN_OUTPUT.load(Ordering::Relaxed) {
        eprint!("{text}");
        return;
    }
    let mut out = std::io::stdout().lock();
    let written = out.write_all(text.as_bytes()).and_then(|()| out.flush());
    match written {
        Ok(()) => {}
        Err(e) if e.kind() == ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => {
            eprintln!("error: cannot write to standard output: {e}");
            std::process::exit(1);
        }
    }
}

/// `print` with a line break.
pub fn println(text: &str) {
    print(&format!("{text}\n"));
}

/// Where an output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Destination {
    /// `-`, `/dev/stdout`: the process's standard output.
    Stdout,
    /// Not a regular file (FIFO, character device, socket, or a file reached through `/dev/fd`
    /// or `/proc`): opened and written in place.
    Direct(PathBuf),
    /// A regular file, existing or not (the path with its symlinks followed): replaced by rename.
    Replace(PathBuf),
}

/// Most symlinks followed from an output path (the kernel's own limit).
const MAX_LINKS: usize = 40;

/// Where `path` leads: symlinks followed one by one (a dangling link leads to the file it names,
/// which is then created), the directories leading to the file resolved.
fn destination(path: &Path) -> std::io::Result<Destination> {
    let standard = ["-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"];
    if standard.iter().any(|s| path.as_os_str() == *s) {
        return Ok(Destination::Stdout);
    }
    let mut at = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        // A descriptor of this process (`/dev/fd/3`, `/dev/stderr`): written through.
        if ["/dev/fd", "/dev/stdin", "/dev/stderr", "/proc"]
            .iter()
            .any(|d| at.starts_with(d))
        {
            return Ok(Destination::Direct(path.to_path_buf()));
        }
        match std::fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&at)?;
                at = match at.parent() {
                    Some(dir) => dir.join(link),
                    None => link,
                };
            }
            Ok(m) if m.is_file() => return Ok(Destination::Replace(resolved(&at))),
            Ok(m) if m.is_dir() => {
                return Err(std::io::Error::new(
                    ErrorKind::IsADirectory,
                    "is a directory; expected a file path",
                ))
            }
            Ok(_) => return Ok(Destination::Direct(path.to_path_buf())),
            Err(e) if e.kind() == ErrorKind::NotFound => {
                return Ok(Destination::Replace(resolved(&at)))
            }
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::new(
        ErrorKind::InvalidInput,
        "too many levels of symbolic links",
    ))
}

/// `path` with its directory resolved (the file itself may not exist yet); as given when the
/// directory cannot be resolved.
fn resolved(path: &Path) -> PathBuf {
    let (Some(name), dir) = (path.file_name(), path.parent()) else {
        return path.to_path_buf();
    };
    let dir = match dir {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    dir.canonicalize()
        .map_or_else(|_| path.to_path_buf(), |d| d.join(name))
}

/// What an output is compared by for aliasing; `None` for `/dev/null`, which takes any number.
fn identity(dest: &Destination) -> Option<PathBuf> {
    match dest {
        Destination::Stdout => Some(PathBuf::from("/dev/stdout")),
        Destination::Direct(p) => {
            let p = p.canonicalize().unwrap_or_else(|_| p.clone());
            (p != Path::new("/dev/null")).then_some(p)
        }
        Destination::Replace(p) => Some(p.clone()),
    }
}

/// Checks every output given (`flag`, path, whether `-` may stand for standard output; `None`:
/// the flag was not given) before any work: its directory exists and takes a new file, it is not
/// a directory, it is not one of `inputs` (which would be overwritten) and no two outputs are the
/// same file.
pub fn check_outputs(inputs: &[&Path], outputs: &[(&str, Option<&Path>)]) -> Result<(), CliError> {
    let inputs: Vec<PathBuf> = inputs
        .iter()
        .filter(|p| p.as_os_str() != "-")
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    let mut seen: Vec<(PathBuf, &str)> = Vec::new();
    for (flag, path) in outputs.iter().filter_map(|&(f, p)| p.map(|p| (f, p))) {
        let shown = path.display();
        if path.file_name().is_none() && path.as_os_str() != "-" {
            return Err(CliError::usage(format!(
                "{flag} {shown}: expected a file path"
            )));
        }
        let dest = destination(path).map_err(|e| match e.kind() {
            ErrorKind::IsADirectory => CliError::usage(format!("{flag} {shown}: {e}")),
            _ => CliError::failed(format!("{flag} {shown}: {e}")),
        })?;
        if dest == Destination::Stdout && !text_output(flag) {
            return Err(CliError::usage(format!(
                "{flag} {shown}: this output is binary; expected a file path (- and /dev/stdout are for text outputs)"
            )));
        }
        if let Destination::Replace(target) = &dest {
            let dir = target.parent().filter(|d| d.is_dir());
            let Some(_) = dir else {
                let dir = path.parent().map(|d| d.display().to_string());
                return Err(CliError::usage(format!(
                    "{flag} {shown}: directory {} does not exist",
                    dir.unwrap_or_default()
                )));
            };
        }
        let Some(key) = identity(&dest) else {
            continue;
        };
        if inputs.contains(&key) {
            return Err(CliError::usage(format!(
                "{flag} {shown}: is also an input of this command and would be overwritten; choose another output path"
            )));
        }
        if let Some((_, other)) = seen.iter().find(|(p, _)| *p == key) {
            return Err(CliError::usage(format!(
                "{flag} {shown}: the same file as {other}; give each output its own path"
            )));
        }
        match &dest {
            Destination::Stdout => STDOUT_IS_AN_OUTPUT.store(true, Ordering::Relaxed),
            Destination::Direct(_) => {}
            // Try the directory with a file of the kind the result will first go to (removed
            // when dropped).
            Destination::Replace(target) => {
                temp_beside(target).map_err(|e| {
                    CliError::failed(format!("{flag} {shown}: cannot write there: {e}"))
                })?;
            }
        }
        seen.push((key, flag));
    }
    Ok(())
}

/// Outputs that are text and may go to standard output.
fn text_output(flag: &str) -> bool {
    flag != "--rrd"
}

/// Where an [`AtomicFile`]'s bytes go until it is committed.
enum Sink {
    /// A temporary file renamed to `target` on commit (removed when dropped uncommitted).
    Temp {
        temp: NamedTempFile,
        target: PathBuf,
    },
    /// Written in place (a FIFO, a device).
    InPlace,
    /// Standard output: a closed pipe ends the process quietly, as in [`print`].
    Stdout,
}

/// An output file under construction: a regular file is written to a temporary file beside it
/// and renamed into place by [`AtomicFile::commit`] (the temporary file is removed when dropped
/// uncommitted, after an error on the way); anything else is written directly.
pub struct AtomicFile {
    dest: PathBuf,
    sink: Sink,
    writer: BufWriter<Box<dyn Write + Send>>,
}

impl AtomicFile {
    pub fn create(dest: &Path) -> Result<AtomicFile, CliError> {
        let cannot =
            |e: std::io::Error| CliError::failed(format!("{}: cannot create: {e}", dest.display()));
        let (sink, out): (Sink, Box<dyn Write + Send>) = match destination(dest).map_err(cannot)? {
            Destination::Stdout => (Sink::Stdout, Box::new(std::io::stdout())),
            Destination::Direct(p) => {
                // A regular file reached through a descriptor is rewritten, as `>` does.
                let regular = std::fs::metadata(&p).is_ok_and(|m| m.is_file());
                let f = OpenOptions::new()
                    .write(true)
                    .truncate(regular)
                    .open(p)
                    .map_err(cannot)?;
                (Sink::InPlace, Box::new(f))
            }
            Destination::Replace(target) => {
                let temp = temp_beside(&target).map_err(cannot)?;
                // A replaced file keeps its permissions.
                if let Ok(m) = std::fs::metadata(&target) {
                    let _ = temp.as_file().set_permissions(m.permissions());
                }
                // The writer's own handle on the temporary file, which stays to be persisted.
                let f = temp.as_file().try_clone().map_err(cannot)?;
                (Sink::Temp { temp, target }, Box::new(f))
            }
        };
        Ok(AtomicFile {
            dest: dest.to_path_buf(),
            sink,
            writer: BufWriter::new(out),
        })
    }

    /// The path the file will have once committed.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Where the bytes are until the commit: the temporary file, if there is one.
    pub fn temporary(&self) -> Option<&Path> {
        match &self.sink {
            Sink::Temp { temp, .. } => Some(temp.path()),
            Sink::InPlace | Sink::Stdout => None,
        }
    }

    /// The writer; an error names the final path.
    pub fn writer(&mut self) -> &mut BufWriter<Box<dyn Write + Send>> {
        &mut self.writer
    }

    /// An I/O error of this file, as a CLI error naming it. On standard output a closed pipe
    /// ends the process quietly with exit 0 (its reader has all it wanted).
    pub fn error(&self, e: std::io::Error) -> CliError {
        if matches!(self.sink, Sink::Stdout) && e.kind() == ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        CliError::failed(format!("{}: cannot write: {e}", self.dest.display()))
    }

    /// Flushes, and moves a temporary file into place once its data are on disk.
    pub fn commit(mut self) -> Result<(), CliError> {
        self.writer.flush().map_err(|e| self.error(e))?;
        let AtomicFile { dest, sink, writer } = self;
        drop(writer);
        match sink {
            Sink::Temp { temp, target } => persist(temp, &target)
                .map_err(|e| CliError::failed(format!("{}: cannot write: {e}", dest.display()))),
            Sink::InPlace | Sink::Stdout => Ok(()),
        }
    }
}

/// Writes a whole file at once, atomically.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let mut f = AtomicFile::create(path)?;
    let written = f.writer().write_all(bytes);
    written.map_err(|e| f.error(e))?;
    f.commit()
}

/// Runs `write(path)` with a path to write to (for a writer that takes a path, such as the Rerun
/// recording's): a temporary file moved into place when it succeeds and removed when it fails,
/// or the output itself when it is not a regular file.
pub fn write_via_path(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), CliError>,
) -> Result<(), CliError> {
    let cannot =
        |e: std::io::Error| CliError::failed(format!("{}: cannot write: {e}", path.display()));
    let target = match destination(path).map_err(cannot)? {
        Destination::Stdout => return write(Path::new("/dev/stdout")),
        Destination::Direct(p) => return write(&p),
        Destination::Replace(target) => target,
    };
    // Removed when dropped, after a failed write.
    let temp = temp_beside(&target).map_err(cannot)?.into_temp_path();
    write(&temp)?;
    persist_path(temp, &target).map_err(cannot)
}

/// Checks an output directory given with `flag` before any work: it is a directory, or it does
/// not exist yet and its parent does (it is created when written).
pub fn check_output_dir(flag: &str, dir: Option<&Path>) -> Result<(), CliError> {
    let Some(dir) = dir else {
        return Ok(());
    };
    let shown = dir.display();
    if dir.exists() {
        if !dir.is_dir() {
            return Err(CliError::usage(format!(
                "{flag} {shown}: is a file; expected a directory"
            )));
        }
        return Ok(());
    }
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(CliError::usage(format!(
            "{flag} {shown}: directory {} does not exist",
            parent.display()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn destinations_follow_links_and_leave_special_files_in_place() {
        for p in ["-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"] {
            assert_eq!(
                destination(Path::new(p)).ok(),
                Some(Destination::Stdout),
                "{p}"
            );
        }
        assert_eq!(
            destination(Path::new("/dev/null")).ok(),
            Some(Destination::Direct(PathBuf::from("/dev/null")))
        );
        assert_eq!(
            destination(Path::new("/dev/stderr")).ok(),
            Some(Destination::Direct(PathBuf::from("/dev/stderr")))
        );
        let dir = std::env::temp_dir().join(format!("arcsim-output-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("real")).expect("dir");
        let link = dir.join("link.json");
        let _ = std::fs::remove_file(&link);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("real/out.json", &link).expect("symlink");
            let real = dir.canonicalize().expect("dir").join("real/out.json");
            assert_eq!(destination(&link).ok(), Some(Destination::Replace(real)));
        }
        assert!(destination(&dir).is_err(), "a directory is no output");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
