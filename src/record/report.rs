//! `simulate --report FILE.html`: one self-contained HTML file of a run. The
//! truss in 3D playing its deployment (three.js, OrbitControls), members
//! coloured by axial force, latches marked as they engage; cable tensions,
//! latch forces and the energy terms against time (uPlot), linked to the time
//! slider; the latch table, the stop reason and the solver's counters.
//!
//! The JavaScript libraries are vendored (`vendor/js/`, versions and sha256
//! in its README) and inlined at compile time, so a report opens from
//! `file://` with no network. The run's data is one JSON document in a
//! `<script type="application/json">` tag ([`ReportData`]).
//!
//! [`ReportRecorder`] is the run loop's recorder (`Recorder`): it captures
//! [`Frame`]s and hands them to a [`ReportBuilder`], which thins them to a
//! frame budget (default [`DEFAULT_FRAME_BUDGET`]): frames are spaced evenly
//! in a measure that adds the simulated time (as a fraction of the run), the
//! largest joint displacement (as a fraction of the truss's size) and the
//! latches' changes of state, so a slow creep, a fast snap and each latching
//! get frames. Latch forces are peak-held over the steps a frame stands for,
//! so a short latch transient keeps its peak in the plot. Positions are
//! rounded to 10 µm, forces and energies to 4 significant digits.

use super::{Frame, FrameLayout, RecordError, Recorder};
use crate::files::AtomicFile;
use crate::run::Stop;
use crate::solver::model::Model;
use crate::solver::{LockEvent, Simulator, SolverStats};
use serde::Serialize;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Frames kept at most in a report (the first and the last step among them).
pub const DEFAULT_FRAME_BUDGET: usize = 400;

const TEMPLATE: &str = include_str!("report.html");
const THREE_JS: &str = include_str!("../../vendor/js/three.module.min.js");
const ORBIT_CONTROLS_JS: &str = include_str!("../../vendor/js/OrbitControls.js");
const UPLOT_JS: &str = include_str!("../../vendor/js/uPlot.iife.min.js");
const UPLOT_CSS: &str = include_str!("../../vendor/js/uPlot.min.css");

/// Why a report could not be made or written.
#[derive(Debug)]
pub enum ReportError {
    /// The layout and a sample disagree (a bug in the caller, not bad input).
    Shape {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    /// No step was recorded.
    Empty,
    /// The data did not serialize.
    Json(String),
    /// Writing the file failed (the path and the system's reason).
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl fmt::Display for ReportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReportError::Shape {
                what,
                expected,
                got,
            } => write!(
                f,
                "--report: a recorded frame has {got} {what}, the layout {expected}"
            ),
            ReportError::Empty => write!(f, "--report: no frame was recorded"),
            ReportError::Json(e) => write!(f, "--report: the data did not serialize: {e}"),
            ReportError::Write { path, source } => {
                write!(f, "cannot write --report {}: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for ReportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ReportError::Write { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// What a report draws that does not change during the run.
#[derive(Clone, Debug, Default)]
pub struct ReportLayout {
    pub model: String,
    pub joints: Vec<String>,
    /// The members drawn: every element's members (`Constraint::members`).
    pub members: Vec<ReportMember>,
    /// Axial forces per frame (the members whose force is recorded: bars and
    /// sleeves, `FrameLayout::members`).
    pub forces: usize,
    /// Each latch's name and the two joints its sleeve spans (its marker
    /// sits halfway between them).
    pub latches: Vec<ReportLatch>,
    /// Series of the cable plot (e.g. each cable's tension at the motor and
    /// at its far end), of the energy plot (the energy terms, J).
    pub cable_series: Vec<String>,
    pub energy_series: Vec<String>,
}

/// A member drawn: its joints, its element's kind, and where its axial
/// force is among a frame's forces (None: not recorded, e.g. a scissor's rods).
#[derive(Clone, Debug, Serialize)]
pub struct ReportMember {
    pub joints: [usize; 2],
    pub kind: String,
    pub force: Option<usize>,
}

#[derive(Clone, Debug, Serialize)]
pub struct ReportLatch {
    pub name: String,
    pub joints: [usize; 2],
}

/// One step as the builder takes it: slices in the layout's order.
pub struct ReportSample<'a> {
    pub t_s: f64,
    /// Joint positions, x y z per joint (m).
    pub x_m: &'a [f64],
    /// Axial forces (N, tension positive; `ReportLayout::forces` of them).
    pub axial_n: &'a [f64],
    /// Per latch: 0 open, 1 latched, 2 engaging (`LatchState::code`).
    pub latch_state: &'a [u8],
    /// Per latch, the force through it (N).
    pub latch_force_n: &'a [f64],
    pub cable_n: &'a [f64],
    pub energy_j: &'a [f64],
}

/// A series of a plot: group (`cable`, `latch`, `energy`), name, values per frame.
#[derive(Clone, Debug, Serialize)]
pub struct ReportSeries {
    pub group: &'static str,
    pub name: String,
    pub values: Vec<f32>,
}

#[derive(Clone, Debug, Serialize)]
pub struct PlotGroup {
    pub group: &'static str,
    pub title: &'static str,
    pub unit: &'static str,
}

/// The frames of a report, one entry per frame in each field.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ReportFrames {
    pub t_s: Vec<f64>,
    /// Joint positions (m), x y z per joint.
    pub x_m: Vec<Vec<f32>>,
    /// Axial forces (N), as `ReportMember::force` indexes them.
    pub axial_n: Vec<Vec<f32>>,
    /// Per latch: 0 open, 1 latched, 2 engaging (`LatchState::code`).
    pub latch_state: Vec<Vec<u8>>,
}

/// Everything a report shows: the JSON document embedded in the HTML file.
#[derive(Clone, Debug, Serialize)]
pub struct ReportData {
    pub title: String,
    pub model: String,
    pub joints: Vec<String>,
    pub members: Vec<ReportMember>,
    pub latches: Vec<ReportLatch>,
    pub frames: ReportFrames,
    pub series: Vec<ReportSeries>,
    pub plot_groups: Vec<PlotGroup>,
    /// The summary's `locks`: every latch event (time, impulse, peak force).
    pub locks: Vec<LockEvent>,
    pub stop_reason: String,
    pub stop_message: String,
    /// As `solver_stats` in `simulate --json`.
    pub solver_stats: SolverStats,
    /// How the frames were thinned, a sentence.
    pub thinning: String,
}

/// How the run ended, for the report's header and tables.
pub struct ReportEnd<'a> {
    pub locks: &'a [LockEvent],
    pub stop_reason: &'a str,
    pub stop_message: &'a str,
    pub solver_stats: &'a SolverStats,
}

/// One kept frame.
struct Kept {
    t_s: f64,
    /// Cumulative thinning measure at this frame.
    at: f64,
    x: Vec<f32>,
    axial: Vec<f32>,
    latch_state: Vec<u8>,
    /// Per latch, the force of largest magnitude since the frame before.
    latch_peak: Vec<f64>,
    cable: Vec<f32>,
    energy: Vec<f32>,
}

/// Takes a run's steps and keeps at most a budget of frames of them: per
/// step [`ReportBuilder::advance`] (is this step due?), and
/// [`ReportBuilder::hold_latch_forces`]; [`ReportBuilder::keep`] the steps
/// that are due and the last one.
pub struct ReportBuilder {
    layout: ReportLayout,
    budget: usize,
    run_s: f64,
    size_m: f64,
    spacing: f64,
    at: f64,
    last_t: Option<f64>,
    last_x: Vec<f64>,
    peak: Vec<f64>,
    kept: Vec<Kept>,
    steps: u64,
    last_kept_step: Option<u64>,
}

/// `v` rounded to `digits` significant digits.
fn sig(v: f64, digits: i32) -> f32 {
    if v == 0.0 || !v.is_finite() {
        return v as f32;
    }
    let p = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    ((v * p).round() / p) as f32
}

/// `v` (m) rounded to 10 µm.
fn pos(v: f64) -> f32 {
    ((v * 1e5).round() / 1e5) as f32
}

fn check(what: &'static str, expected: usize, got: usize) -> Result<(), ReportError> {
    if expected == got {
        Ok(())
    } else {
        Err(ReportError::Shape {
            what,
            expected,
            got,
        })
    }
}

/// The larger in magnitude of `a` and `b`.
fn larger(a: f64, b: f64) -> f64 {
    if b.abs() > a.abs() {
        b
    } else {
        a
    }
}

impl ReportBuilder {
    /// A builder for a run of `run_s` simulated seconds at most (the
    /// thinning's time scale), keeping at most `budget` frames (at least 2).
    pub fn new(layout: ReportLayout, budget: usize, run_s: f64) -> ReportBuilder {
        let budget = budget.max(2);
        ReportBuilder {
            peak: vec![0.0; layout.latches.len()],
            layout,
            budget,
            run_s: if run_s > 0.0 { run_s } else { 1.0 },
            size_m: 0.0,
            spacing: 1.0 / (4.0 * budget as f64),
            at: 0.0,
            last_t: None,
            last_x: Vec::new(),
            kept: Vec::new(),
            steps: 0,
            last_kept_step: None,
        }
    }

    pub fn layout(&self) -> &ReportLayout {
        &self.layout
    }

    /// Frames kept so far.
    pub fn frames(&self) -> usize {
        self.kept.len()
    }

    /// Whether the last step advanced was kept.
    pub fn kept_last(&self) -> bool {
        self.steps > 0 && self.last_kept_step == Some(self.steps)
    }

    /// Takes the state of the next step (time, joint positions, how many
    /// latches changed state in it) into the thinning measure; true when it
    /// is due to be kept.
    pub fn advance(&mut self, t_s: f64, x_m: &[f64], latch_changes: usize) -> bool {
        self.steps += 1;
        match self.last_t {
            None => {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for p in x_m.chunks_exact(3) {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                let d = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
                self.size_m = if d.is_finite() && d > 0.0 { d } else { 1.0 };
            }
            Some(t) => {
                let moved = x_m
                    .chunks_exact(3)
                    .zip(self.last_x.chunks_exact(3))
                    .map(|(a, b)| {
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .fold(0.0, f64::max);
                // (every latch engaging and latching weighs, all together,
                // as much as the run's time: the latching gets frames)
                let latches = self.layout.latches.len().max(1) as f64;
                let inc = (t_s - t).abs() / self.run_s
                    + moved / self.size_m
                    + latch_changes as f64 / (2.0 * latches);
                if inc.is_finite() {
                    self.at += inc;
                }
            }
        }
        self.last_t = Some(t_s);
        self.last_x.clear();
        self.last_x.extend_from_slice(x_m);
        self.kept
            .last()
            .is_none_or(|k| self.at - k.at >= self.spacing)
    }

    /// Per latch, a force of this step (N): the next frame kept shows the
    /// largest in magnitude since the frame before.
    pub fn hold_latch_forces(&mut self, force_n: &[f64]) {
        for (p, &f) in self.peak.iter_mut().zip(force_n) {
            *p = larger(*p, f);
        }
    }

    /// Keeps the step last advanced as a frame.
    pub fn keep(&mut self, s: &ReportSample) -> Result<(), ReportError> {
        let l = &self.layout;
        check("coordinates", 3 * l.joints.len(), s.x_m.len())?;
        check("member forces", l.forces, s.axial_n.len())?;
        check("latch states", l.latches.len(), s.latch_state.len())?;
        check("latch forces", l.latches.len(), s.latch_force_n.len())?;
        check("cable values", l.cable_series.len(), s.cable_n.len())?;
        check("energy terms", l.energy_series.len(), s.energy_j.len())?;
        if self.kept_last() {
            return Ok(());
        }
        let latches = l.latches.len();
        self.hold_latch_forces(s.latch_force_n);
        self.kept.push(Kept {
            t_s: (s.t_s * 1e9).round() / 1e9,
            at: self.at,
            x: s.x_m.iter().map(|&v| pos(v)).collect(),
            axial: s.axial_n.iter().map(|&v| sig(v, 4)).collect(),
            latch_state: s.latch_state.to_vec(),
            latch_peak: std::mem::replace(&mut self.peak, vec![0.0; latches]),
            cable: s.cable_n.iter().map(|&v| sig(v, 4)).collect(),
            energy: s.energy_j.iter().map(|&v| sig(v, 4)).collect(),
        });
        self.last_kept_step = Some(self.steps);
        if self.kept.len() >= self.budget {
            self.thin();
        }
        Ok(())
    }

    /// Doubles the spacing and drops the frames it makes too close, keeping
    /// the first and the last; a dropped frame's latch peaks pass to the
    /// next frame kept.
    fn thin(&mut self) {
        while self.kept.len() >= self.budget {
            self.spacing *= 2.0;
            let old = std::mem::take(&mut self.kept);
            let n = old.len();
            let mut carry: Option<Vec<f64>> = None;
            for (i, mut k) in old.into_iter().enumerate() {
                if let Some(c) = carry.take() {
                    for (p, q) in k.latch_peak.iter_mut().zip(c) {
                        *p = larger(*p, q);
                    }
                }
                let keep = i == 0
                    || i + 1 == n
                    || self
                        .kept
                        .last()
                        .is_none_or(|last| k.at - last.at >= self.spacing);
                if keep {
                    self.kept.push(k);
                } else {
                    carry = Some(k.latch_peak);
                }
            }
        }
    }

    /// The report's data, the run ended as `end` says. (Keep the last step
    /// first, where it was not kept.)
    pub fn finish(self, end: &ReportEnd) -> Result<ReportData, ReportError> {
        if self.kept.is_empty() {
            return Err(ReportError::Empty);
        }
        let l = self.layout;
        let kept = self.kept;
        let mut series = Vec::new();
        for (i, name) in l.cable_series.iter().enumerate() {
            series.push(ReportSeries {
                group: "cable",
                name: name.clone(),
                values: kept.iter().map(|k| k.cable[i]).collect(),
            });
        }
        for (i, latch) in l.latches.iter().enumerate() {
            series.push(ReportSeries {
                group: "latch",
                name: latch.name.clone(),
                values: kept.iter().map(|k| sig(k.latch_peak[i], 4)).collect(),
            });
        }
        for (i, name) in l.energy_series.iter().enumerate() {
            let values: Vec<f32> = kept.iter().map(|k| k.energy[i]).collect();
            // (a term that stays 0 in this run: not drawn)
            if values.iter().any(|&v| v != 0.0) {
                series.push(ReportSeries {
                    group: "energy",
                    name: name.clone(),
                    values,
                });
            }
        }
        let frames = ReportFrames {
            t_s: kept.iter().map(|k| k.t_s).collect(),
            axial_n: kept.iter().map(|k| k.axial.clone()).collect(),
            latch_state: kept.iter().map(|k| k.latch_state.clone()).collect(),
            x_m: kept.into_iter().map(|k| k.x).collect(),
        };
        Ok(ReportData {
            title: format!("{}: deployment report", l.model),
            thinning: format!(
                "{} frames of {} states, spaced evenly in simulated time plus joint motion; \
                 latch forces are the peak over each frame's steps",
                frames.t_s.len(),
                self.steps
            ),
            model: l.model,
            joints: l.joints,
            members: l.members,
            latches: l.latches,
            frames,
            series,
            plot_groups: vec![
                PlotGroup {
                    group: "cable",
                    title: "cable tension",
                    unit: "N",
                },
                PlotGroup {
                    group: "latch",
                    title: "latch forces (peak over each frame; tension positive)",
                    unit: "N",
                },
                PlotGroup {
                    group: "energy",
                    title: "energy terms",
                    unit: "J",
                },
            ],
            locks: end.locks.to_vec(),
            stop_reason: end.stop_reason.to_string(),
            stop_message: end.stop_message.to_string(),
            solver_stats: end.solver_stats.clone(),
        })
    }
}

/// Standard base64 (RFC 4648, padded).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        out.push(A[(n >> 18) as usize & 63] as char);
        out.push(A[(n >> 12) as usize & 63] as char);
        out.push(if c.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if c.len() > 2 {
            A[n as usize & 63] as char
        } else {
            '='
        });
    }
    out
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The report as one HTML document.
pub fn render_html(data: &ReportData) -> Result<String, ReportError> {
    let json = serde_json::to_string(data).map_err(|e| ReportError::Json(e.to_string()))?;
    // (inside <script>: no `</script` or `<!--` can appear once `<` is escaped)
    let json = json.replace('<', "\\u003c");
    let module = |js: &str| format!("data:text/javascript;base64,{}", base64(js.as_bytes()));
    let importmap = serde_json::json!({
        "imports": {
            "three": module(THREE_JS),
            "three/addons/controls/OrbitControls.js": module(ORBIT_CONTROLS_JS),
        }
    })
    .to_string();
    // (one pass each, data last: nothing it holds is taken for a placeholder)
    let html = TEMPLATE
        .replacen("__TITLE__", &html_escape(&data.title), 1)
        .replacen("/*__UPLOT_CSS__*/", UPLOT_CSS, 1)
        .replacen("__IMPORTMAP__", &importmap, 1)
        .replacen("__UPLOT_JS__", UPLOT_JS, 1);
    Ok(html.replacen("__DATA__", &json, 1))
}

/// Writes the report of `data` to `path` atomically; its size (bytes).
pub fn write_report(path: &Path, data: &ReportData) -> Result<u64, ReportError> {
    let html = render_html(data)?;
    let io = |source| ReportError::Write {
        path: path.to_path_buf(),
        source,
    };
    let mut f = AtomicFile::open(path).map_err(io)?;
    f.writer().write_all(html.as_bytes()).map_err(io)?;
    f.commit_io().map_err(io)?;
    Ok(html.len() as u64)
}

/// The report's layout of a model: every element's members drawn, the
/// forces of `FrameLayout::members`, each latch's marker on its sleeve, the
/// cable plot's two series per cable (at the motor and at the far end), the
/// energy terms.
pub fn layout_of(m: &Model, frames: &FrameLayout) -> ReportLayout {
    let mut members = Vec::new();
    for (e, el) in m.elements.iter().enumerate() {
        let js = el.joints();
        let force = frames.members.iter().position(|mb| mb.element == e);
        for &[a, b] in el.members() {
            members.push(ReportMember {
                joints: [js[a], js[b]],
                kind: el.kind().to_string(),
                force,
            });
        }
    }
    let latches = frames
        .latches
        .iter()
        .map(|l| {
            let js = m.elements[l.element].joints();
            let joints = match frames.members.iter().find(|mb| mb.element == l.element) {
                Some(mb) => mb.joints,
                None => [js[0], js[js.len().saturating_sub(1)]],
            };
            ReportLatch {
                name: l.name.clone(),
                joints,
            }
        })
        .collect();
    ReportLayout {
        model: m.name.clone(),
        joints: frames.joints.clone(),
        members,
        forces: frames.members.len(),
        latches,
        cable_series: frames
            .cables
            .iter()
            .flat_map(|c| {
                [
                    format!("{} at the motor", c.name),
                    format!("{} at its end", c.name),
                ]
            })
            .collect(),
        energy_series: ENERGY_TERMS.iter().map(|(n, _)| n.to_string()).collect(),
    }
}

/// An energy term of a frame (J).
type EnergyTerm = fn(&Frame) -> f64;

/// The energy plot's terms (J): name, value in a frame.
const ENERGY_TERMS: [(&str, EnergyTerm); 12] = [
    ("kinetic", |f| f.kinetic_energy_j),
    ("motor work", |f| f.energy.motor_work_j),
    ("cable work", |f| f.energy.cable_work_j),
    ("pulley friction loss", |f| f.energy.friction_loss_j),
    ("damping loss", |f| f.energy.damping_loss_j),
    ("latch impact loss", |f| f.energy.lock_loss_j),
    ("latch damper loss", |f| f.energy.latch_damping_loss_j),
    ("latch spring energy", |f| f.energy.latch_spring_energy_j),
    ("element spring energy", |f| {
        f.energy.element_spring_energy_j
    }),
    ("member strain energy", |f| f.energy.member_strain_energy_j),
    ("member damper loss", |f| f.energy.member_damping_loss_j),
    ("gravity work", |f| f.energy.gravity_work_j),
];

/// `simulate --report FILE.html`: a [`Recorder`] that keeps the run's
/// frames (`Frame::capture` at the steps the thinning keeps, the latches'
/// spring forces at every step for their peaks) and writes the report when
/// the run ends, whatever ended it.
pub struct ReportRecorder {
    path: PathBuf,
    frames: FrameLayout,
    builder: Option<ReportBuilder>,
    force: Vec<f64>,
    /// Per latch, its state at the step before (`LatchState::code`).
    state: Vec<u8>,
    /// Per latch, the peak force of its lock event last seen (N).
    peak_seen: Vec<Option<f64>>,
    /// Frames and bytes written (after `finish`).
    pub written: Option<(usize, u64)>,
}

const OUTPUT: &str = "--report";

/// A latch's state as `Frame::capture` finds it (`LatchState::code`: 0 open,
/// 1 latched, 2 engaging).
fn latch_code(sim: &Simulator, element: usize) -> u8 {
    let s = sim.state();
    if s.transients.iter().any(|t| t.element == element) {
        2
    } else if s.locked.get(element).copied().unwrap_or(false) {
        1
    } else {
        0
    }
}

impl ReportRecorder {
    /// A recorder of `sim`'s run, `run_s` simulated seconds at most (the
    /// thinning's time scale), keeping at most `budget` frames.
    pub fn new(sim: &Simulator, path: &Path, run_s: f64, budget: usize) -> ReportRecorder {
        let frames = FrameLayout::new(sim.model());
        let layout = layout_of(sim.model(), &frames);
        ReportRecorder {
            path: path.to_path_buf(),
            force: vec![0.0; frames.latches.len()],
            peak_seen: vec![None; frames.latches.len()],
            state: frames
                .latches
                .iter()
                .map(|l| latch_code(sim, l.element))
                .collect(),
            frames,
            builder: Some(ReportBuilder::new(layout, budget, run_s)),
            written: None,
        }
    }

    fn error(&self, e: ReportError) -> RecordError {
        match e {
            ReportError::Write { path, source } => RecordError::io(OUTPUT, &path, source),
            e => RecordError::other(OUTPUT, &self.path, e.to_string()),
        }
    }

    fn keep(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let f = Frame::capture(&self.frames, sim);
        let cable: Vec<f64> = f
            .cable_tension_n
            .iter()
            .flat_map(|c| {
                [
                    c.first().copied().unwrap_or(0.0),
                    c.last().copied().unwrap_or(0.0),
                ]
            })
            .collect();
        let energy: Vec<f64> = ENERGY_TERMS.iter().map(|(_, v)| v(&f)).collect();
        let state: Vec<u8> = f.latch_state.iter().map(|s| s.code() as u8).collect();
        let sample = ReportSample {
            t_s: f.t_s,
            x_m: &f.x,
            axial_n: &f.member_force_n,
            latch_state: &state,
            latch_force_n: &f.latch_force_n,
            cable_n: &cable,
            energy_j: &energy,
        };
        let Some(b) = self.builder.as_mut() else {
            return Ok(());
        };
        let kept = b.keep(&sample);
        kept.map_err(|e| self.error(e))
    }
}

impl Recorder for ReportRecorder {
    fn start(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let s = sim.state();
        if let Some(b) = self.builder.as_mut() {
            b.advance(s.t_s, &s.x, 0);
        }
        self.keep(sim)
    }

    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        let Some(b) = self.builder.as_mut() else {
            return Ok(());
        };
        // (a compliant latch's force between the frames: its spring-damper's
        // at the step's end, and its peak inside the step where the solver
        // located one, signed as the force)
        let s = sim.state();
        for ((f, l), seen) in self
            .force
            .iter_mut()
            .zip(&self.frames.latches)
            .zip(&mut self.peak_seen)
        {
            let now = sim.latch_spring_force_n(l.element).unwrap_or(0.0);
            let sign = if now != 0.0 { now } else { *f };
            *f = now;
            let peak = s
                .locks
                .iter()
                .find(|ev| ev.element == l.element)
                .and_then(|ev| ev.peak_force_n);
            if let Some(p) = peak.filter(|p| Some(*p) != *seen) {
                *seen = Some(p);
                *f = larger(now, if sign < 0.0 { -p } else { p });
            }
        }
        b.hold_latch_forces(&self.force);
        let s = sim.state();
        let mut changes = 0;
        for (l, st) in self.frames.latches.iter().zip(&mut self.state) {
            let now = latch_code(sim, l.element);
            if std::mem::replace(st, now) != now {
                changes += 1;
            }
        }
        if b.advance(s.t_s, &s.x, changes) {
            self.keep(sim)?;
        }
        Ok(())
    }

    fn finish(&mut self, sim: &mut Simulator, stop: &Stop) -> Result<(), RecordError> {
        if self.builder.as_ref().is_some_and(|b| !b.kept_last()) {
            self.keep(sim)?;
        }
        let Some(b) = self.builder.take() else {
            return Ok(());
        };
        let data = b
            .finish(&ReportEnd {
                locks: &sim.state().locks,
                stop_reason: stop.reason.label(),
                stop_message: &stop.message,
                solver_stats: sim.solver_stats(),
            })
            .map_err(|e| self.error(e))?;
        let bytes = write_report(&self.path, &data).map_err(|e| self.error(e))?;
        self.written = Some((data.frames.t_s.len(), bytes));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> ReportLayout {
        ReportLayout {
            model: "two <bars>".into(),
            joints: vec!["a".into(), "b".into(), "c".into()],
            members: vec![
                ReportMember {
                    joints: [0, 1],
                    kind: "bar".into(),
                    force: Some(0),
                },
                ReportMember {
                    joints: [1, 2],
                    kind: "sleeve".into(),
                    force: None,
                },
            ],
            forces: 1,
            latches: vec![ReportLatch {
                name: "S1".into(),
                joints: [1, 2],
            }],
            cable_series: vec!["drive".into()],
            energy_series: vec!["kinetic".into(), "none".into()],
        }
    }

    fn run(steps: usize, budget: usize) -> ReportData {
        let mut b = ReportBuilder::new(layout(), budget, steps as f64);
        for i in 0..steps {
            let t = i as f64;
            let x = [
                0.0,
                0.0,
                0.0,
                1.0,
                0.0,
                0.0,
                1.0 + t / steps as f64,
                0.0,
                0.0,
            ];
            // a one-step latch spike at step 337, held but not kept
            b.hold_latch_forces(&[if i == 337 { -50.0 } else { 0.0 }]);
            if b.advance(t, &x, 0) || i + 1 == steps {
                b.keep(&ReportSample {
                    t_s: t,
                    x_m: &x,
                    axial_n: &[1.0],
                    latch_state: &[u8::from(i >= 337)],
                    latch_force_n: &[0.0],
                    cable_n: &[15.0],
                    energy_j: &[0.5, 0.0],
                })
                .unwrap();
            }
        }
        b.finish(&ReportEnd {
            locks: &[],
            stop_reason: "deployed",
            stop_message: "done",
            solver_stats: &SolverStats::default(),
        })
        .unwrap()
    }

    #[test]
    fn thinning_keeps_the_budget_the_ends_and_the_latch_peak() {
        let d = run(10_000, 400);
        let n = d.frames.t_s.len();
        assert!((150..=400).contains(&n), "{n} frames");
        assert_eq!(d.frames.t_s[0], 0.0);
        assert_eq!(*d.frames.t_s.last().unwrap(), 9999.0);
        let latch = d.series.iter().find(|s| s.group == "latch").unwrap();
        assert!(latch.values.contains(&-50.0), "the spike is kept");
        assert!(d.frames.t_s.windows(2).all(|w| w[0] < w[1]));
        // an energy term that stays 0 is not drawn
        assert_eq!(d.series.iter().filter(|s| s.group == "energy").count(), 1);
        // a short run keeps every step
        assert_eq!(run(50, 400).frames.t_s.len(), 50);
    }

    #[test]
    fn the_html_holds_the_data_and_no_network_reference() {
        let html = render_html(&run(20, 400)).unwrap();
        assert!(html.contains("two &lt;bars&gt;: deployment report"));
        assert!(!html.contains("__DATA__") && !html.contains("__IMPORTMAP__"));
        // the title's `<` is escaped inside the JSON too
        assert!(html.contains(r#""model":"two \u003cbars>""#));
        assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
        assert_eq!(base64(b"Man"), "TWFu");
        assert_eq!(base64(b"Ma"), "TWE=");
        assert_eq!(base64(b"M"), "TQ==");
    }

    #[test]
    fn a_wrong_shape_is_an_error_not_a_panic() {
        let mut b = ReportBuilder::new(layout(), 10, 1.0);
        b.advance(0.0, &[0.0; 6], 0);
        let e = b
            .keep(&ReportSample {
                t_s: 0.0,
                x_m: &[0.0; 6],
                axial_n: &[0.0],
                latch_state: &[0],
                latch_force_n: &[0.0],
                cable_n: &[0.0],
                energy_j: &[0.0, 0.0],
            })
            .unwrap_err();
        assert!(e.to_string().contains("6 coordinates"), "{e}");
    }

    /// The bundled mast's report: every member drawn, the sleeves' forces
    /// recorded, every latch in it, latched at the end.
    #[test]
    fn the_mast_report_records_its_latches() {
        let path = format!(
            "{}/../../models/pantograph_mast.toml",
            env!("CARGO_MANIFEST_DIR")
        );
        let lm = crate::model::load(Path::new(&path)).expect("bundled model");
        let mut sim = Simulator::new(lm.model, crate::solver::Options::default()).unwrap();
        let out = std::env::temp_dir().join(format!("report_mast_{}.html", std::process::id()));
        let mut rec = ReportRecorder::new(&sim, &out, 40.0, 50);
        let limits = crate::run::RunLimits {
            dt_s: 0.05,
            until_s: 40.0,
            until_asked: false,
            max_wall_s: None,
            cancel: None,
        };
        let stop = crate::run::run_loop(&mut sim, &lm.checks, limits, &mut [&mut rec]);
        assert!(stop.record_errors.is_empty(), "{:?}", stop.record_errors);
        let (frames, bytes) = rec.written.expect("written");
        assert!((10..=50).contains(&frames), "{frames} frames");
        let html = std::fs::read_to_string(&out).unwrap();
        assert_eq!(html.len() as u64, bytes);
        let _ = std::fs::remove_file(&out);
        for l in &sim.state().locks {
            assert!(html.contains(&format!("\"name\":\"{}\"", l.name)));
        }
        let layout = rec.builder.is_none();
        assert!(layout, "finished");
    }

    #[test]
    fn an_unwritable_path_is_a_record_error_naming_it() {
        let path = format!(
            "{}/../../models/pantograph_mast.toml",
            env!("CARGO_MANIFEST_DIR")
        );
        let lm = crate::model::load(Path::new(&path)).expect("bundled model");
        let mut sim = Simulator::new(lm.model, crate::solver::Options::default()).unwrap();
        let out = Path::new("/nonexistent-dir/r.html");
        let mut rec = ReportRecorder::new(&sim, out, 1.0, 50);
        rec.start(&mut sim).unwrap();
        let stop = Stop {
            reason: crate::run::StopReason::Until,
            message: String::new(),
            wall_time_s: 0.0,
            record_errors: Vec::new(),
        };
        let e = rec.finish(&mut sim, &stop).unwrap_err();
        let shown = e.to_string();
        assert!(
            shown.starts_with("cannot write --report /nonexistent-dir/r.html: "),
            "{shown}"
        );
    }
}
