//! Files written atomically: a temporary sibling renamed onto the target, so
//! a reader sees the old file or the whole new one, never a part.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A temporary sibling of `target`: `.NAME.PID.TAG`, hidden, same directory (so
/// the rename is atomic).
pub fn temp_path(target: &Path, tag: &str) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.{}.{tag}", std::process::id()))
}

/// A file being written: a buffered temporary file that becomes `target` on
/// [`AtomicFile::commit`] (dropped without commit, it is removed).
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    out: Option<BufWriter<File>>,
}

impl AtomicFile {
    pub fn create(target: &Path) -> Result<AtomicFile, String> {
        AtomicFile::open(target).map_err(|e| format!("cannot write {}: {e}", target.display()))
    }

    /// As [`AtomicFile::create`], with the I/O error as it is (the caller
    /// names the path).
    pub fn open(target: &Path) -> std::io::Result<AtomicFile> {
        let temp = temp_path(target, "part");
        let f = File::create(&temp)?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            temp,
            out: Some(BufWriter::new(f)),
        })
    }

    pub fn writer(&mut self) -> &mut BufWriter<File> {
        self.out.as_mut().expect("an uncommitted file has a writer")
    }

    /// Flushes, syncs and renames the temporary file onto the target.
    pub fn commit(self) -> Result<(), String> {
        self.finish(true)
    }

    fn finish(self, sync: bool) -> Result<(), String> {
        let target = self.target.display().to_string();
        self.finish_io(sync)
            .map_err(|e| format!("cannot write {target}: {e}"))
    }

    /// As [`AtomicFile::commit`], with the I/O error as it is.
    pub fn commit_io(self) -> std::io::Result<()> {
        self.finish_io(true)
    }

    fn finish_io(mut self, sync: bool) -> std::io::Result<()> {
        let out = self.out.take().expect("committed once");
        let done = out
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|file| if sync { file.sync_all() } else { Ok(()) })
            .and_then(|_| std::fs::rename(&self.temp, &self.target));
        if done.is_err() {
            let _ = std::fs::remove_file(&self.temp);
        }
        done
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_atomic_with(path, bytes, true)
}

/// Writes `bytes` to `path` atomically, synced to disk or not: unsynced,
/// the file survives the end of the process however it ends (SIGKILL too),
/// not a crash of the machine (for the many small rows of a sweep, whose
/// fsyncs would dominate its time).
pub fn write_atomic_with(path: &Path, bytes: &[u8], sync: bool) -> Result<(), String> {
    let mut f = AtomicFile::create(path)?;
    f.writer()
        .write_all(bytes)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    f.finish(sync)
}
