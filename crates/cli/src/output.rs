//! Writing results. Standard output ends quietly when its reader goes away (`arcsim … | head`),
//! and output files are checked before the work starts (no alias of an input, a directory that
//! exists and takes a new file), written to `NAME.partial` beside the target and renamed into
//! place only when complete, so a failed or interrupted command never leaves a half-written or
//! overwritten file behind.

use std::fs::File;
use std::io::{BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};

use crate::CliError;

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

/// Writes `text` to standard output, control characters escaped ([`printable`]). A closed pipe
/// ends the process quietly with exit 0, as Unix tools do when their reader has all it wanted;
/// other write errors are reported.
pub fn print(text: &str) {
    let text = printable(text);
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

/// Where a path points once the directories leading to it are resolved (the file itself may not
/// exist yet). `None` when its directory does not exist.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    dir.canonicalize().ok().map(|d| d.join(name))
}

fn temp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    path.with_file_name(name)
}

/// Checks every output given (`flag`, path; `None`: the flag was not given) before any work: its
/// directory exists and takes a new file, it is not a directory, it is not one of `inputs` (which
/// would be overwritten) and no two outputs are the same file.
pub fn check_outputs(inputs: &[&Path], outputs: &[(&str, Option<&Path>)]) -> Result<(), CliError> {
    let inputs: Vec<PathBuf> = inputs
        .iter()
        .filter(|p| p.as_os_str() != "-")
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    let mut seen: Vec<(PathBuf, &str)> = Vec::new();
    for (flag, path) in outputs.iter().filter_map(|&(f, p)| p.map(|p| (f, p))) {
        let shown = path.display();
        if path.file_name().is_none() || path.as_os_str() == "-" {
            return Err(CliError::usage(format!(
                "{flag} {shown}: expected a file path"
            )));
        }
        let Some(target) = resolved(path) else {
            let dir = path.parent().map(|d| d.display().to_string());
            return Err(CliError::usage(format!(
                "{flag} {shown}: directory {} does not exist",
                dir.unwrap_or_default()
            )));
        };
        if target.is_dir() {
            return Err(CliError::usage(format!(
                "{flag} {shown}: is a directory; expected a file path"
            )));
        }
        if inputs.contains(&target) {
            return Err(CliError::usage(format!(
                "{flag} {shown}: is also an input of this command and would be overwritten; choose another output path"
            )));
        }
        if let Some((_, other)) = seen.iter().find(|(p, _)| *p == target) {
            return Err(CliError::usage(format!(
                "{flag} {shown}: the same file as {other}; give each output its own path"
            )));
        }
        // Try the very file the result will first go to.
        let tmp = temp_path(path);
        File::create(&tmp)
            .and_then(|_| std::fs::remove_file(&tmp))
            .map_err(|e| CliError::failed(format!("{flag} {shown}: cannot write there: {e}")))?;
        seen.push((target, flag));
    }
    Ok(())
}

/// An output file under construction: written to `NAME.partial`, renamed to `NAME` by
/// [`AtomicFile::commit`], removed when dropped uncommitted (an error on the way).
pub struct AtomicFile {
    dest: PathBuf,
    tmp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    pub fn create(dest: &Path) -> Result<AtomicFile, CliError> {
        let tmp = temp_path(dest);
        let file = File::create(&tmp)
            .map_err(|e| CliError::failed(format!("{}: cannot create: {e}", dest.display())))?;
        Ok(AtomicFile {
            dest: dest.to_path_buf(),
            tmp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The path the file will have once committed.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// The writer; an error names the final path.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        self.writer
            .as_mut()
            .expect("an AtomicFile is only written before commit")
    }

    /// An I/O error of this file, as a CLI error naming it.
    pub fn error(&self, e: std::io::Error) -> CliError {
        CliError::failed(format!("{}: cannot write: {e}", self.dest.display()))
    }

    /// Flushes and moves the file into place.
    pub fn commit(mut self) -> Result<(), CliError> {
        let Some(mut w) = self.writer.take() else {
            return Ok(());
        };
        w.flush().map_err(|e| self.error(e))?;
        drop(w);
        std::fs::rename(&self.tmp, &self.dest).map_err(|e| self.error(e))
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
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

/// Runs `write(tmp_path)` (a writer that takes a path, such as the Rerun recording's) and moves
/// the result into place when it succeeds; removes the partial file when it fails.
pub fn write_via_path(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), CliError>,
) -> Result<(), CliError> {
    let tmp = temp_path(path);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path)
            .map_err(|e| CliError::failed(format!("{}: cannot write: {e}", path.display()))),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
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
