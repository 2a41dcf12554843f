//! `simulate --csv`: every joint coordinate against time, one row per step
//! (the initial state first). Header `t_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,...`,
//! each field quoted per RFC 4180 where it holds a comma, a double quote or a
//! line break (a quote inside doubled), so any joint name reads back whole.

use super::{RecordError, Recorder};
use crate::files::AtomicFile;
use crate::run::Stop;
use crate::solver::Simulator;
use std::io::Write;
use std::path::{Path, PathBuf};

const OUTPUT: &str = "--csv";

/// A CSV field per RFC 4180: as it is, or in double quotes with each quote
/// doubled where it holds a comma, a quote, CR or LF.
pub fn field(s: &str) -> String {
    if s.contains([',', '"', '\r', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The header line (without its line break).
pub fn header(sim: &Simulator) -> String {
    let mut h = String::from("t_s");
    for j in &sim.model().joints {
        for c in ["x", "y", "z"] {
            h.push(',');
            h += &field(&format!("{}_{c}_m", j.name));
        }
    }
    h
}

fn row(out: &mut dyn Write, sim: &Simulator) -> std::io::Result<()> {
    let s = sim.state();
    write!(out, "{}", s.t_s)?;
    for v in &s.x {
        write!(out, ",{v}")?;
    }
    writeln!(out)
}

/// The CSV being written: a temporary sibling renamed onto the path when
/// the run ends (`finish`), whole rows only.
pub struct CsvRecorder {
    path: PathBuf,
    file: Option<AtomicFile>,
}

impl CsvRecorder {
    /// Opens the temporary file (errors name the path).
    pub fn create(path: &Path) -> Result<CsvRecorder, RecordError> {
        let file = AtomicFile::open(path).map_err(|e| RecordError::io(OUTPUT, path, e))?;
        Ok(CsvRecorder {
            path: path.to_path_buf(),
            file: Some(file),
        })
    }

    fn write(
        &mut self,
        f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), RecordError> {
        let file = self
            .file
            .as_mut()
            .ok_or_else(|| RecordError::other(OUTPUT, &self.path, "written after its end"))?;
        f(file.writer()).map_err(|e| RecordError::io(OUTPUT, &self.path, e))
    }
}

impl Recorder for CsvRecorder {
    fn start(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let h = header(sim);
        self.write(|w| {
            writeln!(w, "{h}")?;
            row(w, sim)
        })
    }
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        self.write(|w| row(w, sim))
    }
    fn finish(&mut self, _sim: &mut Simulator, _stop: &Stop) -> Result<(), RecordError> {
        match self.file.take() {
            Some(f) => f
                .commit_io()
                .map_err(|e| RecordError::io(OUTPUT, &self.path, e)),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::field;

    #[test]
    fn fields_quote_per_rfc_4180() {
        assert_eq!(field("a_x_m"), "a_x_m");
        assert_eq!(field("a,\"b\"_x_m"), "\"a,\"\"b\"\"_x_m\"");
        assert_eq!(field("l\nf"), "\"l\nf\"");
    }
}
