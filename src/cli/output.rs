//! Safe output files: every path is checked before a run (not the model, not
//! another output, in a directory that exists and takes a new file), and every
//! file is written atomically (a temporary file in the same directory, renamed
//! over the target when complete), so a failed or interrupted run never leaves
//! a half-written file under the name asked for, nor destroys the file there.

use super::Failure;
use std::fs::File;
use std::path::{Path, PathBuf};

pub use crate::files::{temp_path, write_atomic};

/// The path as the file system would resolve it: the canonical parent
/// directory joined with the file name (the file itself need not exist).
fn resolved(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let name = p.file_name()?;
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// Checks the outputs of a run before it starts: `inputs` are files the run
/// reads (the model), `outputs` the (option, path) pairs it will write.
/// Refuses an output equal to an input or to another output, a directory, a
/// path whose directory does not exist, and a directory that does not take a
/// new file (checked by creating and removing a probe file, so an existing
/// output is left untouched until the run has written its replacement).
pub fn check_outputs(inputs: &[&Path], outputs: &[(&str, &Path)]) -> Result<(), Failure> {
    let inputs: Vec<(PathBuf, &Path)> = inputs
        .iter()
        .filter_map(|p| resolved(p).map(|r| (r, *p)))
        .collect();
    let mut seen: Vec<(PathBuf, &str)> = Vec::new();
    for &(option, path) in outputs {
        let shown = path.display();
        if path.file_name().is_none() || path.is_dir() {
            return Err(Failure::input(format!(
                "{option} {shown} is a directory; give a file name"
            )));
        }
        // (a device, pipe or socket: the output, written whole and renamed
        // onto its path, would replace it; /dev/null too, when run as root)
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(Failure::input(format!(
                "{option} {shown} is not a regular file (a device, pipe or socket), which writing \
                 the output would replace; give a file name"
            )));
        }
        let Some(r) = resolved(path) else {
            return Err(Failure::input(format!(
                "cannot write {option} {shown}: the directory {} does not exist; create it first or give another path",
                path.parent()
                    .filter(|d| !d.as_os_str().is_empty())
                    .unwrap_or(Path::new("."))
                    .display()
            )));
        };
        if let Some((_, input)) = inputs.iter().find(|(i, _)| *i == r) {
            return Err(Failure::input(format!(
                "{option} {shown} is the model file {}; writing it would destroy the model: give another path",
                input.display()
            )));
        }
        if let Some((_, other)) = seen.iter().find(|(o, _)| *o == r) {
            return Err(Failure::input(format!(
                "{option} {shown} is also the path of {other}; each output needs its own file"
            )));
        }
        let probe = temp_path(&r, "probe");
        File::create(&probe)
            .and_then(|_| std::fs::remove_file(&probe))
            .map_err(|e| Failure::input(format!("cannot write {option} {shown}: {e}")))?;
        seen.push((r, option));
    }
    Ok(())
}
