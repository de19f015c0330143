//! Output files written whole or not at all.
//!
//! Every output of a run is first written to a temporary file beside its destination; only
//! when all of them are complete are they renamed into place. If anything fails on the way,
//! the temporary files are removed and no destination is touched.

use std::io::Write;
use std::path::{Path, PathBuf};

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
        Ok(dest.with_file_name(tmp_name))
    }

    /// Moves every staged file into place.
    pub fn commit(mut self) -> Result<(), OutputError> {
        for (tmp, dest) in std::mem::take(&mut self.staged) {
            std::fs::rename(&tmp, &dest).map_err(|e| OutputError::new(&dest, e))?;
        }
        Ok(())
    }
}

impl Drop for OutputBatch {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
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
