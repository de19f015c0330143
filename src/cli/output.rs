//! Output files written whole or not at all.
//!
//! Every output of a run is first written to a temporary file beside its destination; only
//! when all of them are complete are they renamed into place. If anything fails on the way,
//! the temporary files are removed and no destination is touched — also when the run is
//! interrupted (Ctrl-C, SIGTERM: see [`remove_staged_on_interrupt`]), and a run killed
//! outright (SIGKILL, a power cut) has its leftovers removed by the next run that writes to
//! the same place.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// Writes `value` as pretty JSON ending in a newline: every command's `--json` output.
pub(crate) fn write_json(w: &mut dyn Write, value: &impl serde::Serialize) -> std::io::Result<()> {
    serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
    writeln!(w)
}

/// Every temporary file staged and not yet committed or removed, in this process.
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn staged_files() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic while holding the lock leaves a list that is still right.
    STAGED.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget_staged(tmp: &Path) {
    staged_files().retain(|p| p != tmp);
}

/// On SIGINT or SIGTERM, removes every staged temporary file and ends the process with
/// status 130, as a shell reports an interrupted command. Installed once by the CLI.
pub(crate) fn remove_staged_on_interrupt() {
    // Only fails when a handler is already installed, which leaves one in place.
    let _ = ctrlc::set_handler(|| {
        for tmp in staged_files().drain(..) {
            let _ = std::fs::remove_file(tmp);
        }
        std::process::exit(130);
    });
}

/// Removes temporary files of `dest` left by runs that are no longer alive (killed before
/// they could clean up); those of live runs are theirs.
fn remove_stale_temporaries(dest: &Path) {
    let (Some(dir), Some(name)) = (dest.parent(), dest.file_name()) else {
        return;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{}.tmp", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let file_name = file_name.to_string_lossy();
        let Some(rest) = file_name.strip_prefix(&prefix) else {
            continue;
        };
        let pid: String = rest.chars().take_while(char::is_ascii_digit).collect();
        if let Ok(pid) = pid.parse::<u32>()
            && pid != std::process::id()
            && !process_alive(pid)
        {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

#[cfg(unix)]
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    // SAFETY: signal 0 sends nothing; it only asks whether the process exists.
    let result = unsafe { libc::kill(pid, 0) };
    result == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

#[cfg(not(unix))]
fn process_alive(_pid: u32) -> bool {
    true
}

/// An output that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct OutputError {
    /// The destination.
    pub path: String,
    /// What went wrong.
    pub message: String,
}

impl OutputError {
    fn new(path: &Path, e: impl std::fmt::Display) -> Self {
        OutputError {
            path: path.display().to_string(),
            message: e.to_string(),
        }
    }
}

/// Where an output named on the command line goes.
#[derive(Debug, Clone, PartialEq)]
enum Target {
    /// A regular file, or none yet: staged beside it and renamed onto it. The path is the
    /// one symbolic links lead to, so that a link stays a link and its target is replaced.
    File(PathBuf),
    /// `-`: the standard output.
    Stdout,
    /// A device, a FIFO, or a path under `/dev` or `/proc` (`/dev/stdout`): nothing can be
    /// renamed onto it, so the bytes are written to it in place.
    Stream(PathBuf),
}

/// What `dest` is: `-`, a stream, or a file (followed through symbolic links).
fn target_of(dest: &Path) -> Target {
    if dest.as_os_str() == "-" {
        return Target::Stdout;
    }
    // `/dev/stdout` leads through `/proc/self/fd/1` to wherever the shell sent the output,
    // perhaps a regular file it holds open: renaming onto that would lose what it writes.
    if dest.starts_with("/dev") || dest.starts_with("/proc") {
        return Target::Stream(dest.to_path_buf());
    }
    match std::fs::metadata(dest) {
        Ok(m) if !m.is_file() && !m.is_dir() => Target::Stream(dest.to_path_buf()),
        Ok(_) => Target::File(std::fs::canonicalize(dest).unwrap_or_else(|_| dest.into())),
        // A dangling link is written where it points, and the link stays.
        Err(_) => Target::File(link_destination(dest)),
    }
}

/// Where a chain of symbolic links from `path` ends, whether or not a file is there yet.
fn link_destination(path: &Path) -> PathBuf {
    let mut at = path.to_path_buf();
    // A loop of links ends nowhere: the file's own error says so when it is created.
    for _ in 0..40 {
        let Ok(next) = std::fs::read_link(&at) else {
            return at;
        };
        at = match at.parent() {
            Some(dir) => dir.join(next),
            None => next,
        };
    }
    at
}

/// What a staged output still needs when the batch is committed.
#[derive(Debug)]
enum Pending {
    /// A complete temporary file to rename onto the target.
    Rename { tmp: PathBuf, onto: PathBuf },
    /// Bytes for the standard output or a stream.
    Bytes { target: Target, bytes: Vec<u8> },
    /// A temporary file (written by a library by path) to copy to the standard output or a
    /// stream, then remove.
    Copy { tmp: PathBuf, target: Target },
    /// Written to its stream as it was produced: nothing left to do.
    Written,
}

/// A set of outputs that become visible together.
#[derive(Debug, Default)]
pub struct OutputBatch {
    /// Each output's destination as given, and what is left to do at the commit.
    staged: Vec<(PathBuf, Pending)>,
}

impl OutputBatch {
    /// An empty batch.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Stages `dest` with the bytes produced by `write`. A file is staged beside its
    /// destination; for the standard output (`-`) or a stream the bytes are kept until the
    /// commit, so that they too appear whole or not at all.
    pub(crate) fn stage(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), OutputError> {
        let target = self.claim(dest)?;
        let Target::File(onto) = target else {
            let mut bytes = Vec::new();
            write(&mut bytes).map_err(|e| OutputError::new(dest, e))?;
            self.staged
                .push((dest.to_path_buf(), Pending::Bytes { target, bytes }));
            return Ok(());
        };
        let tmp = temp_path(&onto, dest)?;
        let file = std::fs::File::create(&tmp).map_err(|e| OutputError::new(dest, e))?;
        self.staged
            .push((dest.to_path_buf(), Pending::Rename { tmp, onto }));
        let mut w = std::io::BufWriter::new(file);
        write(&mut w).map_err(|e| OutputError::new(dest, e))?;
        w.flush().map_err(|e| OutputError::new(dest, e))?;
        Ok(())
    }

    /// Stages `dest` to be written piece by piece (a run's trace as it is simulated): the
    /// returned writer must be finished before the batch is committed. To the standard
    /// output or a stream the pieces go as they come (a trace of any length is never held).
    pub(crate) fn stage_writer(&mut self, dest: &Path) -> Result<StagedWriter, OutputError> {
        let target = self.claim(dest)?;
        let w: Box<dyn Write + Send> = match &target {
            Target::File(onto) => {
                let tmp = temp_path(onto, dest)?;
                let file = std::fs::File::create(&tmp).map_err(|e| OutputError::new(dest, e))?;
                self.staged.push((
                    dest.to_path_buf(),
                    Pending::Rename {
                        tmp,
                        onto: onto.clone(),
                    },
                ));
                Box::new(file)
            }
            other => {
                self.staged.push((dest.to_path_buf(), Pending::Written));
                open_stream(other).map_err(|e| OutputError::new(dest, e))?
            }
        };
        Ok(StagedWriter {
            dest: dest.to_path_buf(),
            w: std::io::BufWriter::new(w),
        })
    }

    /// Where the staged outputs will appear, in the order they were staged.
    pub(crate) fn destinations(&self) -> Vec<PathBuf> {
        self.staged.iter().map(|(dest, _)| dest.clone()).collect()
    }

    /// Stages a file that a library writes by path itself (e.g. an image encoder): `write` is
    /// given the temporary path to write to.
    pub(crate) fn stage_with_path(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&Path) -> Result<(), String>,
    ) -> Result<(), OutputError> {
        let target = self.claim(dest)?;
        let (tmp, pending) = match target {
            Target::File(onto) => {
                let tmp = temp_path(&onto, dest)?;
                (tmp.clone(), Pending::Rename { tmp, onto })
            }
            // Beside nothing: the system's temporary folder, under a name that keeps the
            // extension the encoder reads.
            target => {
                let name = dest.file_name().map_or("output".into(), |n| n.to_owned());
                let tmp = temp_path(&std::env::temp_dir().join(name), dest)?;
                (tmp.clone(), Pending::Copy { tmp, target })
            }
        };
        self.staged.push((dest.to_path_buf(), pending));
        write(&tmp).map_err(|e| OutputError::new(dest, e))
    }

    /// The target of `dest`, refusing a second output to the standard output (two outputs
    /// interleaved there could not be told apart).
    fn claim(&self, dest: &Path) -> Result<Target, OutputError> {
        let target = target_of(dest);
        if target == Target::Stdout {
            if STDOUT_TAKEN.load(Ordering::SeqCst) {
                return Err(OutputError::new(
                    dest,
                    "only one output can go to the standard output",
                ));
            }
            take_stdout();
        }
        Ok(target)
    }

    /// Moves every staged file into place, then writes what goes to the standard output or
    /// a stream.
    pub(crate) fn commit(mut self) -> Result<(), OutputError> {
        // Every stream is opened before any file is renamed: one that cannot be opened (a
        // device's path that is not there) leaves the files as they were.
        let mut opened = Vec::new();
        for (dest, pending) in &self.staged {
            if let Pending::Bytes { target, .. } | Pending::Copy { target, .. } = pending {
                opened.push(open_stream(target).map_err(|e| OutputError::new(dest, e))?);
            }
        }
        let mut opened = opened.into_iter();
        let staged = std::mem::take(&mut self.staged);
        let (files, streams): (Vec<_>, Vec<_>) = staged
            .into_iter()
            .partition(|(_, p)| matches!(p, Pending::Rename { .. }));
        for (dest, pending) in files {
            let Pending::Rename { tmp, onto } = &pending else {
                continue;
            };
            let renamed = std::fs::rename(tmp, onto);
            if renamed.is_err() {
                // Put back, so that dropping the batch removes it with the rest.
                self.staged.push((dest.clone(), pending));
                self.staged.extend(streams);
                return renamed.map_err(|e| OutputError::new(&dest, e));
            }
            forget_staged(tmp);
        }
        for (dest, pending) in streams {
            if let Some(w) = matches!(pending, Pending::Bytes { .. } | Pending::Copy { .. })
                .then(|| opened.next())
                .flatten()
            {
                write_pending(&pending, w).map_err(|e| OutputError::new(&dest, e))?;
            }
            if let Pending::Copy { tmp, .. } = &pending {
                let _ = std::fs::remove_file(tmp);
                forget_staged(tmp);
            }
        }
        Ok(())
    }
}

/// Writes what waited for the commit to its stream.
fn write_pending(pending: &Pending, mut w: Box<dyn Write + Send>) -> std::io::Result<()> {
    match pending {
        Pending::Bytes { bytes, .. } => {
            w.write_all(bytes)?;
            w.flush()
        }
        Pending::Copy { tmp, .. } => {
            std::io::copy(&mut std::fs::File::open(tmp)?, &mut w)?;
            w.flush()
        }
        Pending::Rename { .. } | Pending::Written => Ok(()),
    }
}

/// The temporary file of a destination: beside `onto` (where it will be renamed to), hidden,
/// named by this process; `dest` (as the user gave it) names it in errors.
fn temp_path(onto: &Path, dest: &Path) -> Result<PathBuf, OutputError> {
    remove_stale_temporaries(onto);
    let name = onto
        .file_name()
        .ok_or_else(|| OutputError::new(dest, "not a file name"))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp{}", std::process::id()));
    // Keep the extension last: image encoders choose the format from it.
    if let Some(ext) = onto.extension() {
        tmp_name.push(".");
        tmp_name.push(ext);
    }
    let tmp = onto.with_file_name(tmp_name);
    staged_files().push(tmp.clone());
    Ok(tmp)
}

/// The options whose files go into a folder the command makes where it is not there yet:
/// their folder is not asked to exist before the run.
const FOLDER_MADE: &[&str] = &["--write-compensation"];

/// A file named on the command line: the option or argument that names it (`--json`, the
/// program) and its path, where given.
pub(crate) type Named<'a> = (&'a str, Option<&'a Path>);

/// Refuses, before any work, outputs that cannot all be written as asked: the standard
/// output (`-`) named for more than one (two outputs interleaved there could not be told
/// apart), one file named for two outputs (the later would replace the earlier, leaving
/// half of what was asked), or an output naming a file the run reads (what the run made of
/// it would replace it). Streams (`/dev/null`, a FIFO) take any number of outputs.
pub(crate) fn outputs_apart<'a>(
    inputs: &[Named<'a>],
    outputs: &[Named<'a>],
) -> Result<(), OutputError> {
    let given = |named: &[Named<'a>]| -> Vec<(&'a str, &'a Path)> {
        named
            .iter()
            .filter_map(|&(what, p)| Some((what, p?)))
            .collect()
    };
    let outputs = given(outputs);
    let dashes = outputs.iter().filter(|(_, p)| p.as_os_str() == "-").count();
    if dashes > 1 {
        return Err(OutputError::new(
            Path::new("-"),
            "only one output can go to the standard output",
        ));
    }
    let read: Vec<(&str, PathBuf)> = (given(inputs).into_iter())
        .filter(|(_, p)| p.is_file())
        .filter_map(|(what, p)| Some((what, file_place(p)?)))
        .collect();
    for &(what, path) in &outputs {
        if path.as_os_str() == "-" || FOLDER_MADE.contains(&what) {
            continue;
        }
        let folder = path.parent().filter(|f| !f.as_os_str().is_empty());
        if let Some(folder) = folder.filter(|f| !f.is_dir()) {
            let message = format!("{what}: there is no folder {}", folder.display());
            return Err(OutputError::new(path, message));
        }
    }
    let mut written: Vec<(&str, PathBuf)> = Vec::new();
    for (what, path) in outputs {
        let Some(at) = file_place(path) else {
            continue;
        };
        if let Some((input, _)) = read.iter().find(|(_, p)| *p == at) {
            let message =
                format!("{what} names {input}, which the run reads: it would be replaced");
            return Err(OutputError::new(path, message));
        }
        if let Some((first, _)) = written.iter().find(|(_, p)| *p == at) {
            let message = format!("named for both {first} and {what}: a file holds one output");
            return Err(OutputError::new(path, message));
        }
        written.push((what, at));
    }
    Ok(())
}

/// Where an output to `path` lands as a file, absolute, so that two spellings of one place
/// compare equal: the file its symbolic links lead to, or for one not there yet, its name in
/// its folder's real path. None for `-` and streams, which are not replaced.
fn file_place(path: &Path) -> Option<PathBuf> {
    let Target::File(at) = target_of(path) else {
        return None;
    };
    if let Ok(real) = std::fs::canonicalize(&at) {
        return Some(real);
    }
    let name = at.file_name()?;
    let dir = (at.parent())
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    Some(
        std::fs::canonicalize(dir)
            .unwrap_or_else(|_| dir.to_path_buf())
            .join(name),
    )
}

/// Whether an output of this process took the standard output.
static STDOUT_TAKEN: AtomicBool = AtomicBool::new(false);

/// The standard output as the data's, once an output takes it: on Unix a duplicate of the
/// original descriptor 1, which itself is pointed at the standard error, so that what the
/// command prints for people (its summary, what it wrote) goes there and the standard output
/// carries the data alone.
static DATA_OUT: Mutex<Option<std::fs::File>> = Mutex::new(None);

/// Takes the standard output for data (see [`DATA_OUT`]).
fn take_stdout() {
    STDOUT_TAKEN.store(true, Ordering::SeqCst);
    let _ = std::io::stdout().flush();
    #[cfg(unix)]
    {
        use std::os::fd::FromRawFd;
        // SAFETY: plain descriptor calls on the process's own standard streams; the
        // duplicate is owned by the `File` alone.
        let data = unsafe {
            let fd = libc::dup(1);
            if fd < 0 || libc::dup2(2, 1) < 0 {
                return;
            }
            std::fs::File::from_raw_fd(fd)
        };
        *DATA_OUT.lock().unwrap_or_else(|e| e.into_inner()) = Some(data);
    }
}

/// A writer to the standard output's data or to a stream (appended to: a regular file
/// behind `/dev/stdout` keeps what was written to it before).
fn open_stream(target: &Target) -> std::io::Result<Box<dyn Write + Send>> {
    match target {
        Target::Stdout => {
            let data = DATA_OUT.lock().unwrap_or_else(|e| e.into_inner());
            match data.as_ref() {
                Some(file) => Ok(Box::new(file.try_clone()?)),
                None => Ok(Box::new(std::io::stdout())),
            }
        }
        Target::Stream(path) | Target::File(path) => Ok(Box::new(
            std::fs::OpenOptions::new().append(true).open(path)?,
        )),
    }
}

/// A staged output being written piece by piece.
pub struct StagedWriter {
    dest: PathBuf,
    w: std::io::BufWriter<Box<dyn Write + Send>>,
}

impl std::fmt::Debug for StagedWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StagedWriter")
            .field("dest", &self.dest)
            .finish_non_exhaustive()
    }
}

impl StagedWriter {
    /// Writes the next piece.
    pub(crate) fn write(
        &mut self,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), OutputError> {
        write(&mut self.w).map_err(|e| OutputError::new(&self.dest, e))
    }

    /// Completes the file (its batch still decides whether it appears).
    pub(crate) fn finish(mut self) -> Result<(), OutputError> {
        self.w.flush().map_err(|e| OutputError::new(&self.dest, e))
    }
}

impl Drop for OutputBatch {
    fn drop(&mut self) {
        for (_, pending) in &self.staged {
            if let Pending::Rename { tmp, .. } | Pending::Copy { tmp, .. } = pending {
                let _ = std::fs::remove_file(tmp);
                forget_staged(tmp);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_appears_unless_committed() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.txt"), dir.path().join("b.txt"));
        {
            let mut batch = OutputBatch::new();
            batch.stage(&a, |w| w.write_all(b"one")).unwrap();
            let failed = batch.stage(&b, |_| Err(std::io::Error::other("disk full")));
            assert!(failed.is_err());
        }
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no file left behind"
        );
        let mut batch = OutputBatch::new();
        batch.stage(&a, |w| w.write_all(b"one")).unwrap();
        batch.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "one");
    }
}
