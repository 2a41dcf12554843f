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
//! [`ReportBuilder`] takes one [`ReportSample`] per step and thins them to a
//! frame budget (default [`DEFAULT_FRAME_BUDGET`]): frames are spaced evenly
//! in a measure that adds the simulated time (as a fraction of the run) and
//! the largest joint displacement (as a fraction of the truss's size), so a
//! slow creep and a fast snap both get frames. Latch forces are peak-held
//! over the steps a frame stands for, so a short latch transient keeps its
//! peak in the plot. Positions are rounded to 10 µm, forces and energies to
//! 4 significant digits.

use crate::solver::{LockEvent, SolverStats};
use serde::Serialize;
use std::fmt;
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
    Write { path: PathBuf, reason: String },
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
            ReportError::Write { path, reason } => {
                write!(f, "cannot write --report {}: {reason}", path.display())
            }
        }
    }
}

impl std::error::Error for ReportError {}

/// What a report draws that does not change during the run.
#[derive(Clone, Debug, Default)]
pub struct ReportLayout {
    pub model: String,
    pub joints: Vec<String>,
    /// Each member's joints (indices into `joints`) and kind (e.g. `bar`, `sleeve`).
    pub members: Vec<[usize; 2]>,
    pub member_kinds: Vec<String>,
    /// Each latch's name and the two joints its sleeve spans (its marker
    /// sits halfway between them).
    pub latches: Vec<ReportLatch>,
    /// Series of the cable plot (e.g. each cable's tension at the motor and
    /// at its far end), of the energy plot (the energy terms, J).
    pub cable_series: Vec<String>,
    pub energy_series: Vec<String>,
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
    /// Axial force per member (N, tension positive); empty when not known.
    pub axial_n: &'a [f64],
    /// Per latch: 0 open, 1 engaging (a compliant latch's transient), 2 latched.
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
    /// Axial force per member (N); empty when not recorded.
    pub axial_n: Vec<Vec<f32>>,
    /// Per latch: 0 open, 1 engaging, 2 latched.
    pub latch_state: Vec<Vec<u8>>,
}

/// Everything a report shows: the JSON document embedded in the HTML file.
#[derive(Clone, Debug, Serialize)]
pub struct ReportData {
    pub title: String,
    pub model: String,
    pub joints: Vec<String>,
    pub members: Vec<[usize; 2]>,
    pub member_kinds: Vec<String>,
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

/// Takes the run's steps and keeps at most a budget of frames of them.
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
    /// The latest step when it is not kept (it becomes the last frame).
    tail: Option<Kept>,
    steps: u64,
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
            tail: None,
            steps: 0,
        }
    }

    pub fn layout(&self) -> &ReportLayout {
        &self.layout
    }

    /// Frames kept so far (the latest step counted where not kept).
    pub fn frames(&self) -> usize {
        self.kept.len() + usize::from(self.tail.is_some())
    }

    /// Records one step.
    pub fn push(&mut self, s: &ReportSample) -> Result<(), ReportError> {
        let l = &self.layout;
        check("coordinates", 3 * l.joints.len(), s.x_m.len())?;
        if !s.axial_n.is_empty() {
            check("member forces", l.members.len(), s.axial_n.len())?;
        }
        check("latch states", l.latches.len(), s.latch_state.len())?;
        check("latch forces", l.latches.len(), s.latch_force_n.len())?;
        check("cable values", l.cable_series.len(), s.cable_n.len())?;
        check("energy terms", l.energy_series.len(), s.energy_j.len())?;
        self.steps += 1;
        match self.last_t {
            None => {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for p in s.x_m.chunks_exact(3) {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                let d = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
                self.size_m = if d.is_finite() && d > 0.0 { d } else { 1.0 };
            }
            Some(t) => {
                let moved = s
                    .x_m
                    .chunks_exact(3)
                    .zip(self.last_x.chunks_exact(3))
                    .map(|(a, b)| {
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .fold(0.0, f64::max);
                let inc = (s.t_s - t).abs() / self.run_s + moved / self.size_m;
                if inc.is_finite() {
                    self.at += inc;
                }
            }
        }
        self.last_t = Some(s.t_s);
        self.last_x.clear();
        self.last_x.extend_from_slice(s.x_m);
        for (p, &f) in self.peak.iter_mut().zip(s.latch_force_n) {
            if f.abs() > p.abs() {
                *p = f;
            }
        }
        let frame = Kept {
            t_s: s.t_s,
            at: self.at,
            x: s.x_m.iter().map(|&v| pos(v)).collect(),
            axial: s.axial_n.iter().map(|&v| sig(v, 4)).collect(),
            latch_state: s.latch_state.to_vec(),
            latch_peak: self.peak.clone(),
            cable: s.cable_n.iter().map(|&v| sig(v, 4)).collect(),
            energy: s.energy_j.iter().map(|&v| sig(v, 4)).collect(),
        };
        let due = self
            .kept
            .last()
            .is_none_or(|k| self.at - k.at >= self.spacing);
        if due {
            self.kept.push(frame);
            self.tail = None;
            self.peak.iter_mut().for_each(|p| *p = 0.0);
            if self.kept.len() >= self.budget {
                self.thin();
            }
        } else {
            self.tail = Some(frame);
        }
        Ok(())
    }

    /// Doubles the spacing and drops the frames it makes too close, keeping
    /// the first and the last; a dropped frame's latch peaks pass to the
    /// next frame kept.
    fn thin(&mut self) {
        self.spacing *= 2.0;
        let old = std::mem::take(&mut self.kept);
        let n = old.len();
        let mut carry: Option<Vec<f64>> = None;
        for (i, mut k) in old.into_iter().enumerate() {
            if let Some(c) = carry.take() {
                for (p, q) in k.latch_peak.iter_mut().zip(c) {
                    if q.abs() > p.abs() {
                        *p = q;
                    }
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

    /// The report's data, the run ended as `end` says.
    pub fn finish(mut self, end: &ReportEnd) -> Result<ReportData, ReportError> {
        if let Some(t) = self.tail.take() {
            self.kept.push(t);
        }
        if self.kept.len() > self.budget {
            self.thin();
        }
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
            series.push(ReportSeries {
                group: "energy",
                name: name.clone(),
                values: kept.iter().map(|k| k.energy[i]).collect(),
            });
        }
        let frames = ReportFrames {
            t_s: kept.iter().map(|k| k.t_s).collect(),
            axial_n: if kept.iter().all(|k| k.axial.len() == l.members.len())
                && !l.members.is_empty()
            {
                kept.iter().map(|k| k.axial.clone()).collect()
            } else {
                Vec::new()
            },
            latch_state: kept.iter().map(|k| k.latch_state.clone()).collect(),
            x_m: kept.into_iter().map(|k| k.x).collect(),
        };
        Ok(ReportData {
            title: format!("{}: deployment report", l.model),
            thinning: format!(
                "{} frames of {} steps, spaced evenly in simulated time plus joint motion; \
                 latch forces are the peak over each frame's steps",
                frames.t_s.len(),
                self.steps
            ),
            model: l.model,
            joints: l.joints,
            members: l.members,
            member_kinds: l.member_kinds,
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
                    title: "latch forces (peak over each frame)",
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

/// Writes the report of `data` to `path` atomically.
pub fn write_report(path: &Path, data: &ReportData) -> Result<u64, ReportError> {
    let html = render_html(data)?;
    crate::files::write_atomic(path, html.as_bytes()).map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        reason: e
            .strip_prefix(&format!("cannot write {}: ", path.display()))
            .unwrap_or(&e)
            .to_string(),
    })?;
    Ok(html.len() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> ReportLayout {
        ReportLayout {
            model: "two <bars>".into(),
            joints: vec!["a".into(), "b".into(), "c".into()],
            members: vec![[0, 1], [1, 2]],
            member_kinds: vec!["bar".into(), "sleeve".into()],
            latches: vec![ReportLatch {
                name: "S1".into(),
                joints: [1, 2],
            }],
            cable_series: vec!["drive".into()],
            energy_series: vec!["kinetic_j".into()],
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
            // a one-step latch spike at step 337
            let f = if i == 337 { -50.0 } else { 0.0 };
            b.push(&ReportSample {
                t_s: t,
                x_m: &x,
                axial_n: &[1.0, -2.0],
                latch_state: &[u8::from(i >= 337) * 2],
                latch_force_n: &[f],
                cable_n: &[15.0],
                energy_j: &[0.5],
            })
            .unwrap();
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
        let e = b
            .push(&ReportSample {
                t_s: 0.0,
                x_m: &[0.0; 6],
                axial_n: &[],
                latch_state: &[0],
                latch_force_n: &[0.0],
                cable_n: &[0.0],
                energy_j: &[0.0],
            })
            .unwrap_err();
        assert!(e.to_string().contains("6 coordinates"), "{e}");
    }
}
