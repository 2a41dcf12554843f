//! `simulate --vtk DIR`: the run as a ParaView time series, `run.pvd` (a
//! VTK XML collection: one `DataSet` per recorded step, `timestep` = the
//! simulated time in s) over `frame_00000.vtp`, `frame_00001.vtp`, ... (VTK
//! XML PolyData, ASCII): points are the joints (m) with point data
//! `velocity_m_s` (3 components) and `mass_kg`; lines are the members (bars
//! and sleeves, `FrameLayout::members`) with cell data `axial_force_n`
//! (tension positive), `length_m`, `kind` (`MemberKind::code`: 0 bar,
//! 1 sleeve) and `latch_state` (`LatchState::code`: 0 open, 1 latched,
//! 2 engaging; -1 for a member that is no latch). Plain XML written here:
//! the format is a few elements, and a Rust crate for it would bring a
//! dependency tree for what `write!` does. Numbers are written in Rust's
//! shortest round-trip form, so a reader gets the frame's values exactly.

use super::{Frame, FrameLayout, RecordError, Recorder, Thinning};
use crate::files::AtomicFile;
use crate::run::Stop;
use crate::solver::Simulator;
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

const OUTPUT: &str = "--vtk";

/// The collection file of a series in `dir`.
pub fn pvd_path(dir: &Path) -> PathBuf {
    dir.join("run.pvd")
}

/// The name of the `i`-th recorded frame's file.
pub fn frame_name(i: usize) -> String {
    format!("frame_{i:05}.vtp")
}

fn array<T: std::fmt::LowerExp>(
    out: &mut String,
    ty: &str,
    name: Option<&str>,
    comps: usize,
    vals: impl Iterator<Item = T>,
) {
    let name = name.map(|n| format!(" Name=\"{n}\"")).unwrap_or_default();
    let _ = write!(
        out,
        "        <DataArray type=\"{ty}\"{name} NumberOfComponents=\"{comps}\" format=\"ascii\">"
    );
    for (i, v) in vals.enumerate() {
        out.push(if i % (3 * comps.max(1)) == 0 {
            '\n'
        } else {
            ' '
        });
        let _ = write!(out, "{v:e}");
    }
    out.push_str("\n        </DataArray>\n");
}

/// A field-data array: VTK's reader takes its length from
/// `NumberOfTuples` (without it the array reads empty).
fn field_array(out: &mut String, name: &str, vals: &[f64]) {
    let _ = write!(
        out,
        "        <DataArray type=\"Float64\" Name=\"{name}\" NumberOfTuples=\"{}\" format=\"ascii\">\n",
        vals.len()
    );
    let v: Vec<String> = vals.iter().map(|x| format!("{x:e}")).collect();
    out.push_str(&v.join(" "));
    out.push_str("\n        </DataArray>\n");
}

fn ints(out: &mut String, name: &str, vals: impl Iterator<Item = i64>) {
    let _ = writeln!(
        out,
        "        <DataArray type=\"Int64\" Name=\"{name}\" format=\"ascii\">"
    );
    let v: Vec<String> = vals.map(|x| x.to_string()).collect();
    out.push_str(&v.join(" "));
    out.push_str("\n        </DataArray>\n");
}

/// A PolyData file's opening up to its one piece's: the header, one
/// field-data array (field data belong to the dataset, before its pieces)
/// and the piece of the layout's joints and members.
fn open_polydata(layout: &FrameLayout, field: &str, vals: &[f64]) -> String {
    let (np, nl) = (layout.joints.len(), layout.members.len());
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    s.push_str("  <PolyData>\n");
    s.push_str("    <FieldData>\n");
    field_array(&mut s, field, vals);
    s.push_str("    </FieldData>\n");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{np}\" NumberOfVerts=\"0\" NumberOfLines=\"{nl}\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
    );
    s
}

/// The VTK XML PolyData of one frame.
pub fn polydata(layout: &FrameLayout, f: &Frame) -> String {
    // (the time of the frame, for a reader of one file alone)
    let mut s = open_polydata(layout, "TimeValue", &[f.t_s]);
    s.push_str("      <PointData Vectors=\"velocity_m_s\" Scalars=\"mass_kg\">\n");
    array(&mut s, "Float64", Some("velocity_m_s"), 3, f.v.iter());
    array(
        &mut s,
        "Float64",
        Some("mass_kg"),
        1,
        layout.joint_mass_kg.iter(),
    );
    s.push_str("      </PointData>\n");
    s.push_str("      <CellData Scalars=\"axial_force_n\">\n");
    array(
        &mut s,
        "Float64",
        Some("axial_force_n"),
        1,
        f.member_force_n.iter(),
    );
    array(
        &mut s,
        "Float64",
        Some("length_m"),
        1,
        f.member_length_m.iter(),
    );
    ints(
        &mut s,
        "kind",
        layout.members.iter().map(|m| m.kind.code() as i64),
    );
    ints(
        &mut s,
        "latch_state",
        layout
            .members
            .iter()
            .map(|m| m.latch.map_or(-1, |l| f.latch_state[l].code() as i64)),
    );
    s.push_str("      </CellData>\n");
    s.push_str("      <Points>\n");
    array(&mut s, "Float64", Some("Points"), 3, f.x.iter());
    s.push_str("      </Points>\n");
    lines(&mut s, layout);
    s.push_str("    </Piece>\n  </PolyData>\n</VTKFile>\n");
    s
}

/// `analyze --modes-vtk FILE`: the truss at the geometry the modes were
/// found at (points the joints, lines the members, as a frame's), with
/// point data `mode_01`, `mode_02`, ... (each mode's shape, 3 components,
/// the largest joint displacement 1) and `mass_kg`, and field data
/// `frequency_hz` (one value per mode, in order). In ParaView, Warp By
/// Vector with a mode's array draws it.
pub fn modes_polydata(
    layout: &FrameLayout,
    x: &[f64],
    modes: &crate::solver::modes::Modes,
) -> String {
    let f: Vec<f64> = modes.modes.iter().map(|m| m.frequency_hz).collect();
    let mut s = open_polydata(layout, "frequency_hz", &f);
    s.push_str("      <PointData Scalars=\"mass_kg\">\n");
    for (k, m) in modes.modes.iter().enumerate() {
        let name = format!("mode_{:02}", k + 1);
        array(&mut s, "Float64", Some(&name), 3, m.shape.iter().flatten());
    }
    array(
        &mut s,
        "Float64",
        Some("mass_kg"),
        1,
        layout.joint_mass_kg.iter(),
    );
    s.push_str("      </PointData>\n");
    s.push_str("      <Points>\n");
    array(&mut s, "Float64", Some("Points"), 3, x.iter());
    s.push_str("      </Points>\n");
    lines(&mut s, layout);
    s.push_str("    </Piece>\n  </PolyData>\n</VTKFile>\n");
    s
}

/// The members as VTK lines.
fn lines(s: &mut String, layout: &FrameLayout) {
    s.push_str("      <Lines>\n");
    ints(
        s,
        "connectivity",
        layout
            .members
            .iter()
            .flat_map(|m| m.joints.map(|j| j as i64)),
    );
    ints(
        s,
        "offsets",
        (1..=layout.members.len()).map(|k| 2 * k as i64),
    );
    s.push_str("      </Lines>\n");
}

/// The collection of the frames written: (time, file name) per frame.
pub fn collection(frames: &[(f64, String)]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (t, file) in frames {
        let _ = writeln!(
            s,
            "    <DataSet timestep=\"{t:e}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    s
}

fn write_file(path: &Path, text: &str) -> Result<(), RecordError> {
    let mut f = AtomicFile::open(path).map_err(|e| RecordError::io(OUTPUT, path, e))?;
    f.writer()
        .write_all(text.as_bytes())
        .map_err(|e| RecordError::io(OUTPUT, path, e))?;
    f.commit_io().map_err(|e| RecordError::io(OUTPUT, path, e))
}

/// The series being written into a directory: each frame's file as it is
/// recorded (thinned as the history), the collection at the end.
pub struct VtkRecorder {
    dir: PathBuf,
    thin: Thinning,
    layout: FrameLayout,
    frames: Vec<(f64, String)>,
    last_step: Option<u64>,
}

impl VtkRecorder {
    pub fn new(sim: &Simulator, dir: &Path, thin: Thinning) -> VtkRecorder {
        VtkRecorder {
            dir: dir.to_path_buf(),
            thin,
            layout: FrameLayout::new(sim.model()),
            frames: Vec::new(),
            last_step: None,
        }
    }

    fn record(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let f = Frame::capture(&self.layout, sim);
        let name = frame_name(self.frames.len());
        write_file(&self.dir.join(&name), &polydata(&self.layout, &f))?;
        self.frames.push((f.t_s, name));
        self.last_step = Some(f.step);
        Ok(())
    }
}

impl Recorder for VtkRecorder {
    fn start(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        self.record(sim)
    }
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        if self.thin.keeps(sim.state().steps) {
            self.record(sim)?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulator, _stop: &Stop) -> Result<(), RecordError> {
        if self.last_step != Some(sim.state().steps) {
            self.record(sim)?;
        }
        write_file(&pvd_path(&self.dir), &collection(&self.frames))
    }
}
