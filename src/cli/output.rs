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
pub fn remove_staged_on_interrupt() {
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

/// A set of outputs that become visible together.
#[derive(Debug, Default)]
pub struct OutputBatch {
    staged: Vec<(PathBuf, PathBuf)>,
}

impl OutputBatch {
    /// An empty batch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stages `dest` with the bytes produced by `write`.
    pub fn stage(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), OutputError> {
        let tmp = self.temp_path(dest)?;
        let file = std::fs::File::create(&tmp).map_err(|e| OutputError::new(dest, e))?;
        self.staged.push((tmp.clone(), dest.to_path_buf()));
        let mut w = std::io::BufWriter::new(file);
        write(&mut w).map_err(|e| OutputError::new(dest, e))?;
        w.flush().map_err(|e| OutputError::new(dest, e))?;
        Ok(())
    }

    /// Stages `dest` to be written piece by piece (a run's trace as it is simulated): the
    /// returned writer must be finished before the batch is committed.
    pub fn stage_writer(&mut self, dest: &Path) -> Result<StagedWriter, OutputError> {
        let tmp = self.temp_path(dest)?;
        let file = std::fs::File::create(&tmp).map_err(|e| OutputError::new(dest, e))?;
        self.staged.push((tmp, dest.to_path_buf()));
        Ok(StagedWriter {
            dest: dest.to_path_buf(),
            w: std::io::BufWriter::new(file),
        })
    }

    /// Where the staged outputs will appear, in the order they were staged.
    pub fn destinations(&self) -> Vec<PathBuf> {
        self.staged.iter().map(|(_, dest)| dest.clone()).collect()
    }

    /// Stages a file that a library writes by path itself (e.g. an image encoder): `write` is
    /// given the temporary path to write to.
    pub fn stage_with_path(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&Path) -> Result<(), String>,
    ) -> Result<(), OutputError> {
        let tmp = self.temp_path(dest)?;
        self.staged.push((tmp.clone(), dest.to_path_buf()));
        write(&tmp).map_err(|e| OutputError::new(dest, e))
    }

    fn temp_path(&self, dest: &Path) -> Result<PathBuf, OutputError> {
        remove_stale_temporaries(dest);
        let name = dest
            .file_name()
            .ok_or_else(|| OutputError::new(dest, "not a file name"))?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".tmp{}", std::process::id()));
        // Keep the extension last: image encoders choose the format from it.
        if let Some(ext) = dest.extension() {
            tmp_name.push(".");
            tmp_name.push(ext);
        }
        let tmp = dest.with_file_name(tmp_name);
        staged_files().push(tmp.clone());
        Ok(tmp)
    }

    /// Moves every staged file into place.
    pub fn commit(mut self) -> Result<(), OutputError> {
        for (tmp, dest) in std::mem::take(&mut self.staged) {
            let renamed = std::fs::rename(&tmp, &dest);
            if renamed.is_err() {
                // Put back, so that dropping the batch removes it with the rest.
                self.staged.push((tmp, dest.clone()));
            } else {
                forget_staged(&tmp);
            }
            renamed.map_err(|e| OutputError::new(&dest, e))?;
        }
        Ok(())
    }
}

/// A staged output being written piece by piece.
#[derive(Debug)]
pub struct StagedWriter {
    dest: PathBuf,
    w: std::io::BufWriter<std::fs::File>,
}

impl StagedWriter {
    /// Writes the next piece.
    pub fn write(
        &mut self,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), OutputError> {
        write(&mut self.w).map_err(|e| OutputError::new(&self.dest, e))
    }

    /// Completes the file (its batch still decides whether it appears).
    pub fn finish(mut self) -> Result<(), OutputError> {
        self.w.flush().map_err(|e| OutputError::new(&self.dest, e))
    }
}

impl Drop for OutputBatch {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
            forget_staged(tmp);
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
