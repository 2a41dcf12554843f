//! The clap front end: `simulate`, `analyze`, `generate`, `bench`, `sweep`, `node`.
//! Exit status 0 on success, 2 on bad input (arguments, model files), 1 when a
//! run fails part-way (what was computed until then is still written).

use crate::model::{self, generate};
use crate::solver::checks::RunChecks;
use crate::solver::{mobility, Options, Simulator, SolverKind};
use clap::{Args, Parser, Subcommand, ValueEnum};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod interrupt;
pub(crate) mod output;
mod plot;
mod simulate;
mod sweep;
pub use sweep::generator as sweep_generator;
mod sweep_plot;

/// Writes one `warning:` line on stderr; a failed write is ignored (never a panic).
pub(crate) fn warn(message: &str) {
    let _ = writeln!(std::io::stderr(), "warning: {message}");
}

#[derive(Parser, Debug)]
#[command(
    name = "truss-deploy",
    version = concat!(env!("CARGO_PKG_VERSION"), " (commit ", env!("TRUSS_DEPLOY_COMMIT"), ")"),
    about = "Deployment dynamics of space deployable truss structures"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Run offline to full deployment (or --until); summary and lock table on stdout.
    #[command(
        after_help = "Example: truss-deploy simulate models/pantograph_mast.toml --json run.json\n\nStop reasons, exit statuses and the JSON keys: docs/cli.md"
    )]
    Simulate(simulate::SimulateArgs),
    /// Rank, mechanisms, states of self-stress and redundant rows, before and after all locks.
    #[command(
        after_help = "Example: truss-deploy analyze models/double_ring.toml --json mobility.json"
    )]
    Analyze(AnalyzeArgs),
    /// Write a parametric model file.
    #[command(
        after_help = "Example: truss-deploy generate mast --units 8 -o mast8.toml\n\nThe format it writes: docs/model-format.md"
    )]
    Generate(GenerateArgs),
    /// Time the stepping loop (no I/O).
    #[command(
        after_help = "Example: truss-deploy bench models/double_ring_synchronized.toml --steps 500 --json bench.json"
    )]
    Bench(BenchArgs),
    /// Monte-Carlo and grid studies: many samples of a model with scattered parameters,
    /// one Parquet row each, summary and plots (docs/sweeps.md).
    Sweep(sweep::SweepArgs),
    /// Run the ROS 2 node: step in real time, publish over DDS (see launch_notes.md).
    #[cfg(feature = "ros")]
    #[command(
        after_help = "ROS 2 arguments, after the others: --ros-args [-r FROM:=TO]... [-p NAME:=VALUE]... \
                      [--params-file FILE]... [--log-level LEVEL] [--] (rcl's syntax; launch_notes.md)\n\n\
                      Example: truss-deploy node models/pantograph_mast.toml --rate 50 --record live.mcap"
    )]
    Node(crate::node::NodeArgs),
    /// Drive a running node: ease the cable tension as deploy_fraction nears 1
    /// (`--offline MODEL`: compare with constant tension in-process, no DDS).
    #[cfg(feature = "ros")]
    #[command(
        after_help = "Example: truss-deploy controller --offline models/pantograph_mast.toml"
    )]
    Controller(crate::node::controller::ControllerArgs),
}

#[derive(Args, Debug)]
struct AnalyzeArgs {
    /// Model file (TOML).
    model: PathBuf,
    /// Write the counts, the redundant rows and the rows per element as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// The first N natural frequencies and mode shapes of the deployed,
    /// locked truss (docs/modes.md).
    #[arg(long, value_name = "N")]
    modes: Option<usize>,
    /// Draw the first modes (up to 6) as an SVG (needs --modes).
    #[arg(long, value_name = "FILE", requires = "modes")]
    modes_svg: Option<PathBuf>,
    /// Write the truss and every mode's shape as VTK PolyData for ParaView
    /// (needs --modes).
    #[arg(long, value_name = "FILE.vtp", requires = "modes")]
    modes_vtk: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Kind {
    Mast,
    Ring,
    Sail,
}

#[derive(Args, Debug)]
struct GenerateArgs {
    /// What to generate: `mast` (pantograph mast, 1-500 units), `ring` (double-ring truss,
    /// 6-360 sides), `sail` (sail array, 1-100 bays).
    kind: Kind,
    /// Model file to write (TOML).
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// mast: number of scissor units (1 to 500).
    #[arg(long, default_value_t = generate::MastParams::default().units)]
    units: usize,
    /// ring: number of sides (6 to 360).
    #[arg(long, default_value_t = generate::ring::RingParams::default().sides)]
    sides: usize,
    /// ring: the synchronized ring instead (square frames, one mechanism, part-folded
    /// start, every sleeve at one instant); the value names its gears: both (the
    /// default), axial, radial or none.
    #[arg(long, num_args = 0..=1, default_missing_value = "both", conflicts_with = "stow")]
    sync: Option<String>,
    /// ring: the one-mechanism stowing ring instead (parallelogram bays and square radial
    /// frames that shear to a bundle, no gears, held at post O0; it deploys to full lock
    /// as one mechanism, every sleeve at one instant; see docs/double_ring_stowing.md).
    #[arg(long)]
    stow: bool,
    /// ring: the bay-by-bay ring (the default): stowed to a bundle, its inner ring raised
    /// on sheared radial frames, ball-jointed inner chords, every diagonal latching and
    /// compliant gears at the outer posts; many mechanisms, the frames and then the bays
    /// latch in turn, held at post O0 (see docs/double_ring_stowing.md).
    #[arg(long, conflicts_with_all = ["sync", "stow"])]
    bay_by_bay: bool,
    /// ring: how the ring is held: `hub` (at its centre; the synchronized ring's
    /// default), `frame0` (synchronized ring, at post O0), `post` (post O0 clamped to
    /// a boom; the stowing ring's default) or `bus` (post O0 clamped to a
    /// free-floating spacecraft bus: no support, joint damping 0 unless --damping).
    #[arg(long)]
    mount: Option<String>,
    /// ring, --mount bus: the bus's mass (kg; default 100).
    #[arg(long)]
    bus_mass_kg: Option<f64>,
    /// ring, --mount bus: the bus's principal inertias about its centre along x, y, z
    /// (kg m^2; default 10,12,14).
    #[arg(long, value_delimiter = ',')]
    bus_inertia: Option<Vec<f64>>,
    /// ring, --mount bus: the bus centre's distance outward of post O0 (m; default 1.5).
    #[arg(long)]
    bus_offset_m: Option<f64>,
    /// sail: number of bays (1 to 100).
    #[arg(long, default_value_t = generate::sail::SailParams::default().bays)]
    bays: usize,
    /// mast: scissor rod length (m).
    #[arg(long, allow_negative_numbers = true)]
    rod_length_m: Option<f64>,
    /// Lumped mass per joint (kg).
    #[arg(long, allow_negative_numbers = true)]
    joint_mass_kg: Option<f64>,
    /// Constant motor tension of each drive cable (N).
    #[arg(long, allow_negative_numbers = true)]
    tension_n: Option<f64>,
    /// Cable-pulley friction coefficient.
    #[arg(long, allow_negative_numbers = true)]
    mu: Option<f64>,
    /// Viscous damping per joint (N s/m).
    #[arg(long, allow_negative_numbers = true)]
    damping: Option<f64>,
    /// Angle at the start (deg): mast, rod angle from the horizontal (default 5); ring, tilt of
    /// the outer bays' chords, 0 = deployed (default 75; 35 with --sync, e.g. 1 to study the latch); sail, rod
    /// angle from the vertical (default 1).
    #[arg(long, allow_negative_numbers = true)]
    start_deg: Option<f64>,
    /// mast, sail: angle at which the sleeves latch (deg; defaults 60 and 55). The ring latches flat.
    #[arg(long, allow_negative_numbers = true)]
    deploy_deg: Option<f64>,
    /// mast, ring: compliant latches of this stiffness on every sleeve (N/m); rigid latches without it.
    #[arg(long, allow_negative_numbers = true)]
    latch_stiffness: Option<f64>,
    /// mast, ring: damping of the compliant latches (N s/m; needs --latch-stiffness).
    #[arg(long, allow_negative_numbers = true)]
    latch_damping: Option<f64>,
    /// ring (bay-by-bay): stiffness of the compliant gears at the outer posts (N/m; default 1000).
    #[arg(long, allow_negative_numbers = true)]
    gear_stiffness: Option<f64>,
    /// ring (bay-by-bay): damping of the gears (N s/m; default 5).
    #[arg(long, allow_negative_numbers = true)]
    gear_damping: Option<f64>,
    /// ring (bay-by-bay): end stops of this stiffness (N/m) at every sleeve's stroke end, the
    /// length it takes along the symmetric fold farthest from its lock plus 5 mm (an `end_stop`
    /// element each). Default: none up to 18 sides, 1e4 above (where bays fold the wrong way
    /// without them); 0 for none.
    #[arg(long, allow_negative_numbers = true)]
    stroke_stops: Option<f64>,
    /// ring (bay-by-bay): damping of the end stops (N s/m; default 50; needs --stroke-stops).
    #[arg(long, allow_negative_numbers = true)]
    stroke_stop_damping: Option<f64>,
    /// ring: inner chord (m; default the paper's 0.6167). The paper's chords make the ring's
    /// depth its mean chord at 18 sides, so that it folds to a bundle: on n sides the same rule
    /// gives c_o (1 - sin(pi/n)) / (1 + sin(pi/n)) (0.7353 m at 36; see docs/double_ring_stowing.md),
    /// the bay-by-bay ring's default above 18 sides.
    #[arg(long, allow_negative_numbers = true)]
    inner_chord_m: Option<f64>,
    /// ring: members `elastic` along their axis (`[solver] elastic_members`; the bay-by-bay
    /// ring's default) or `rigid` (the default of --stow and --sync).
    #[arg(long, value_enum)]
    members: Option<MembersArg>,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum MembersArg {
    Elastic,
    Rigid,
}

#[derive(Args, Debug)]
struct BenchArgs {
    /// Model file (TOML).
    model: PathBuf,
    /// Linear solver: sparse (range-space LDL^T and conjugate gradients) or dense (SVD, the
    /// paper's null-space method).
    #[arg(long, value_enum, default_value_t = SolverArg::Sparse)]
    solver: SolverArg,
    /// Steps to time (1 to 1,000,000).
    #[arg(long, default_value_t = 200)]
    steps: usize,
    /// Write the median time per step and the real-time factor as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum SolverArg {
    Dense,
    Sparse,
}

impl From<SolverArg> for SolverKind {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Dense => SolverKind::Dense,
            SolverArg::Sparse => SolverKind::Sparse,
        }
    }
}

/// A failure with its exit status.
/// The node's output files (`--record`, `--timing`) checked as a run's are:
/// not the model, not each other, in a directory that exists and takes files.
#[cfg(feature = "ros")]
fn node_outputs(a: &crate::node::NodeArgs) -> Result<(), Failure> {
    let outputs: Vec<(&str, &std::path::Path)> = [("--record", &a.record), ("--timing", &a.timing)]
        .into_iter()
        .filter_map(|(o, p)| p.as_deref().map(|p| (o, p)))
        .collect();
    output::check_outputs(&[a.model.as_path()], &outputs)
}

/// `--latch-stiffness` / `--latch-damping`: a compliant latch, or None (rigid).
fn latch_option(a: &GenerateArgs) -> Result<Option<generate::LatchParams>, Failure> {
    match (a.latch_stiffness, a.latch_damping) {
        (None, None) => Ok(None),
        (None, Some(_)) => Err(Failure::input(
            "--latch-damping needs --latch-stiffness (a compliant latch)",
        )),
        (Some(k), c) => Ok(Some(generate::LatchParams {
            stiffness_n_per_m: k,
            damping_n_s_per_m: c.unwrap_or(0.0),
        })),
    }
}

/// `--gear-stiffness`, `--gear-damping`, `--stroke-stops`,
/// `--stroke-stop-damping`: only for the bay-by-bay ring.
fn bay_by_bay_options(
    a: &GenerateArgs,
    p: generate::ring::RingParams,
) -> Result<generate::ring::RingParams, Failure> {
    let given = [
        ("--gear-stiffness", a.gear_stiffness),
        ("--gear-damping", a.gear_damping),
        ("--stroke-stops", a.stroke_stops),
        ("--stroke-stop-damping", a.stroke_stop_damping),
    ];
    if let (false, Some((name, _))) = (p.bay_by_bay, given.iter().find(|g| g.1.is_some())) {
        return Err(Failure::input(format!(
            "{name} is an option of the bay-by-bay ring (the default `generate ring`), not of --sync or --stow"
        )));
    }
    // (--stroke-stops 0: none, also where the ring's size brings them)
    let stroke_k = match a.stroke_stops {
        Some(k) => Some(k).filter(|&k| k != 0.0),
        None => p.stroke_stop.as_ref().map(|s| s.stiffness_n_per_m),
    };
    if a.stroke_stop_damping.is_some() && stroke_k.is_none() {
        return Err(Failure::input(
            "--stroke-stop-damping needs stroke stops (--stroke-stops K, K > 0)",
        ));
    }
    for (name, v) in given {
        if let Some(v) = v {
            let zero_ok = name.ends_with("damping") || name == "--stroke-stops";
            if !(v.is_finite() && v >= 0.0) || (v == 0.0 && !zero_ok) {
                return Err(Failure::input(format!(
                    "{name} {v}: give a finite stiffness > 0 (N/m) or damping >= 0 (N s/m)"
                )));
            }
        }
    }
    let gear = generate::LatchParams {
        stiffness_n_per_m: a.gear_stiffness.unwrap_or(p.gear.stiffness_n_per_m),
        damping_n_s_per_m: a.gear_damping.unwrap_or(p.gear.damping_n_s_per_m),
    };
    let stroke_stop = stroke_k.map(|k| generate::LatchParams {
        stiffness_n_per_m: k,
        damping_n_s_per_m: a
            .stroke_stop_damping
            .or(p.stroke_stop.as_ref().map(|s| s.damping_n_s_per_m))
            .unwrap_or(50.0),
    });
    Ok(generate::ring::RingParams {
        gear,
        stroke_stop,
        ..p
    })
}

pub struct Failure {
    pub code: i32,
    pub message: String,
}

impl Failure {
    pub fn input(message: impl Into<String>) -> Self {
        Failure {
            code: 2,
            message: message.into(),
        }
    }
    pub fn run(message: impl Into<String>) -> Self {
        Failure {
            code: 1,
            message: message.into(),
        }
    }
}

pub fn main() -> i32 {
    // `--ros-args ... [--]` sections (as launch_ros passes them) are the node's.
    #[cfg(feature = "ros")]
    let (argv, ros_args) = crate::node::rosargs::split_argv(std::env::args_os());
    #[cfg(not(feature = "ros"))]
    let (argv, ros_args): (Vec<std::ffi::OsString>, Vec<std::ffi::OsString>) =
        (std::env::args_os().collect(), Vec::new());
    let cli = match Cli::try_parse_from(argv) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
    };
    #[cfg(feature = "ros")]
    let is_node = matches!(cli.cmd, Cmd::Node(_));
    #[cfg(not(feature = "ros"))]
    let is_node = false;
    if !ros_args.is_empty() && !is_node {
        let _ = writeln!(
            std::io::stderr(),
            "error: --ros-args belongs to `truss-deploy node`"
        );
        return 2;
    }
    let result = match cli.cmd {
        Cmd::Simulate(a) => simulate::run(a),
        Cmd::Analyze(a) => analyze(a),
        Cmd::Generate(a) => generate_cmd(a),
        Cmd::Bench(a) => bench(a),
        Cmd::Sweep(a) => sweep::run(a),
        #[cfg(feature = "ros")]
        Cmd::Node(mut a) => node_outputs(&a).and_then(|_| {
            a.ros_args = ros_args;
            crate::node::run_blocking(a)
                .map(|_| ())
                .map_err(|e| match e {
                    crate::node::NodeError::Input(m) => Failure::input(m),
                    crate::node::NodeError::Run(m) => Failure::run(m),
                })
        }),
        #[cfg(feature = "ros")]
        Cmd::Controller(a) => controller_cmd(a),
    };
    match result {
        Ok(()) => 0,
        Err(f) => {
            // (a full or closed stderr is ignored: the exit status still tells)
            let _ = writeln!(std::io::stderr(), "error: {}", f.message);
            f.code
        }
    }
}

pub fn load(path: &Path) -> Result<model::LoadedModel, Failure> {
    model::load(path).map_err(|e| Failure::input(e.to_string()))
}

pub fn make_simulator(path: &Path, solver: SolverKind) -> Result<Simulator, Failure> {
    make_simulator_from(path, solver).map(|(sim, _)| sim)
}

/// The simulator of a model file, and the file's run checks.
pub fn make_simulator_from(
    path: &Path,
    solver: SolverKind,
) -> Result<(Simulator, RunChecks), Failure> {
    let m = load(path)?;
    let sim = Simulator::new(
        m.model,
        Options {
            solver,
            ..Options::default()
        },
    )
    .map_err(|e| Failure::input(format!("{}: {e}", path.display())))?;
    Ok((sim, m.checks))
}

/// Writes `value` as pretty JSON, atomically (a failed write exits 1: the
/// input was good, the run's result is lost).
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), Failure> {
    let text = serde_json::to_string_pretty(value).expect("summary serializes") + "\n";
    output::write_atomic(path, text.as_bytes()).map_err(Failure::run)
}

/// What `analyze` finds (`analyze --json`; the Python package's `Model.analyze`).
#[derive(Serialize)]
pub struct AnalyzeJson {
    model: String,
    coordinates: usize,
    rows: usize,
    rank: usize,
    mechanisms: usize,
    self_stress: usize,
    rows_locked: usize,
    rank_locked: usize,
    mechanisms_locked: usize,
    self_stress_locked: usize,
    /// Where the locked analysis was made: "reference" or "initial" geometry.
    locked_geometry: &'static str,
    /// Why the model cannot deploy (null when nothing was found): see
    /// `solver::checks::cannot_deploy`.
    cannot_deploy: Option<String>,
    initial: mobility::Mobility,
    locked: mobility::Mobility,
    /// `analyze --modes N`: the deployed truss's natural modes (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    modes: Option<crate::solver::modes::Modes>,
}

/// Refuses a geometry whose Jacobian is not finite (the SVD of the rank
/// decision would not end on it).
fn finite_jacobian(
    model: &crate::solver::Model,
    x: &[f64],
    locked: &[bool],
    what: &str,
) -> Result<(), Failure> {
    let mut jac = crate::solver::jacobian::Jacobian::pattern(model, locked);
    jac.fill(model, x);
    for b in &jac.blocks {
        let w = crate::solver::jacobian::Jacobian::width(b);
        let vals = &jac.values[b.offset..b.offset + b.rows * w];
        if vals.iter().any(|v| !v.is_finite()) {
            let el = &model.elements[b.element];
            let names: Vec<&str> = el
                .joints()
                .iter()
                .map(|&j| model.joints[j].name.as_str())
                .collect();
            return Err(Failure::input(format!(
                "the {what} geometry makes {} element `{}` degenerate (joints {} coincide or are not finite): its constraint directions are undefined; fix the positions of these joints",
                el.kind(), el.name(), names.join(", ")
            )));
        }
    }
    Ok(())
}

fn analyze(a: AnalyzeArgs) -> Result<(), Failure> {
    let loaded = load(&a.model)?;
    if let Some(j) = &a.json {
        output::check_outputs(&[a.model.as_path()], &[("--json", j.as_path())])?;
    }
    if let Some(svg) = &a.modes_svg {
        output::check_outputs(&[a.model.as_path()], &[("--modes-svg", svg.as_path())])?;
    }
    if let Some(vtp) = &a.modes_vtk {
        output::check_outputs(&[a.model.as_path()], &[("--modes-vtk", vtp.as_path())])?;
    }
    if a.modes == Some(0) {
        return Err(Failure::input(
            "--modes 0: ask for at least one mode".to_string(),
        ));
    }
    let n_joints = loaded.model.n_joints();
    let file = a.model.display().to_string();
    let mut report = analysis(loaded, &file)?;
    let (before, after, geometry) = (&report.initial, &report.locked, report.locked_geometry);
    let cannot_deploy = &report.cannot_deploy;
    say!(
        "model {} ({} joints, {} coordinates)",
        report.model,
        n_joints,
        before.coordinates
    );
    say!(
        "{:<22} {:>8} {:>8} {:>11} {:>12}",
        "",
        "rows",
        "rank",
        "mechanisms",
        "self-stress"
    );
    say!(
        "{:<22} {:>8} {:>8} {:>11} {:>12}",
        "before locks",
        before.rows,
        before.rank,
        before.mechanisms,
        before.self_stress
    );
    say!(
        "{:<22} {:>8} {:>8} {:>11} {:>12}",
        format!("all locked ({geometry})"),
        after.rows,
        after.rank,
        after.mechanisms,
        after.self_stress
    );
    say!("rows per element type (before locks):");
    for p in &before.per_element {
        say!(
            "  {:<18} {:>5} elements {:>6} rows",
            p.kind,
            p.elements,
            p.rows
        );
    }
    match &cannot_deploy {
        Some(why) => say!("diagnosis: cannot deploy: {why}"),
        None => say!("diagnosis: the drive moves the truss at its initial geometry"),
    }
    if !before.redundant_rows.is_empty() {
        let shown: Vec<_> = before.redundant_rows.iter().take(12).cloned().collect();
        say!(
            "redundant rows (before locks): {}{}",
            shown.join(", "),
            if before.redundant_rows.len() > 12 {
                format!(", ... ({} in all)", before.redundant_rows.len())
            } else {
                String::new()
            }
        );
    }
    if let Some(count) = a.modes {
        let model = load(&a.model)?.model;
        let lin = crate::solver::modes::Linearization::deployed(&model);
        let modes = crate::solver::modes::natural_modes(&model, &lin, count)
            .map_err(|e| Failure::run(format!("{file}: no modes: {e}")))?;
        print_modes(&modes);
        if let Some(svg) = &a.modes_svg {
            plot::modes_svg(svg, &model, &lin.x, &modes).map_err(Failure::run)?;
            say!("mode shapes drawn in {}", svg.display());
        }
        if let Some(vtp) = &a.modes_vtk {
            let layout = crate::record::FrameLayout::new(&model);
            let text = crate::record::vtk::modes_polydata(&layout, &lin.x, &modes);
            output::write_atomic(vtp, text.as_bytes()).map_err(Failure::run)?;
            say!("mode shapes written to {} (VTK PolyData)", vtp.display());
        }
        report.modes = Some(modes);
    }
    if let Some(j) = &a.json {
        write_json(j, &report)?;
    }
    Ok(())
}

/// The table of `analyze --modes`.
fn print_modes(m: &crate::solver::modes::Modes) {
    say!(
        "natural modes ({} geometry, every sleeve latched): {} degrees of freedom on the rigid rows' tangent space ({} coordinates, {} rigid rows of rank {}), {} elastic member rows, preload up to {:.4e} N",
        m.geometry, m.degrees_of_freedom, m.coordinates, m.rigid_rows, m.rigid_rank, m.member_rows, m.max_preload_n
    );
    if m.mechanisms > 0 || m.unstable > 0 {
        say!(
            "{} mechanisms (zero frequency), {} unstable (omega^2 < 0)",
            m.mechanisms,
            m.unstable
        );
    }
    say!(
        "{:>5} {:>15} {:>11} {:<18} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7}",
        "mode",
        "frequency_hz",
        "kind",
        "motion",
        "tx",
        "ty",
        "tz",
        "rx",
        "ry",
        "rz"
    );
    for (i, mode) in m.modes.iter().enumerate() {
        let kind = match mode.kind {
            crate::solver::modes::ModeKind::Elastic => "elastic",
            crate::solver::modes::ModeKind::Mechanism => "mechanism",
            crate::solver::modes::ModeKind::Unstable => "unstable",
        };
        let p = mode.participation;
        say!(
            "{:>5} {:>15.6e} {:>11} {:<18} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
            i + 1,
            mode.frequency_hz,
            kind,
            mode.motion,
            p[0],
            p[1],
            p[2],
            p[3],
            p[4],
            p[5]
        );
    }
}

/// `analyze` of a loaded model (`file` names it in errors): the mobility
/// before and after all locks, and why it cannot deploy, if it cannot.
pub fn analysis(loaded: model::LoadedModel, file: &str) -> Result<AnalyzeJson, Failure> {
    let m = &loaded.model;
    let (free, all) = mobility::lock_sets(m);
    let (geometry, xl) = match &m.reference {
        Some(r) => ("reference", r.as_slice()),
        None => ("initial", m.x0.as_slice()),
    };
    let err_in = |f: Failure| Failure::input(format!("{file}: {}", f.message));
    finite_jacobian(m, &m.x0, &free, "initial").map_err(err_in)?;
    finite_jacobian(m, xl, &all, geometry).map_err(err_in)?;
    let (before, after) = mobility::before_and_after_locks(m);
    // The initial state as a run starts from it (accelerations under the drive).
    let sim = Simulator::new(loaded.model, Options::default())
        .map_err(|e| Failure::input(format!("{file}: {e}")))?;
    let m = sim.model();
    let cannot_deploy = crate::solver::checks::cannot_deploy(m, sim.state());
    Ok(AnalyzeJson {
        model: m.name.clone(),
        coordinates: before.coordinates,
        rows: before.rows,
        rank: before.rank,
        mechanisms: before.mechanisms,
        self_stress: before.self_stress,
        rows_locked: after.rows,
        rank_locked: after.rank,
        mechanisms_locked: after.mechanisms,
        self_stress_locked: after.self_stress,
        locked_geometry: geometry,
        cannot_deploy,
        initial: before,
        locked: after,
        modes: None,
    })
}

/// `generate` alone, as a sweep's base generator calls it (`sweep::generator`).
#[derive(Parser, Debug)]
#[command(name = "truss-deploy")]
struct GenerateOnly {
    #[command(flatten)]
    args: GenerateArgs,
}

impl GenerateOnly {
    /// Parses `generate KIND ...` (the first element names the command).
    fn try_parse_from_args(argv: &[String]) -> Result<GenerateArgs, String> {
        GenerateOnly::try_parse_from(argv)
            .map(|g| g.args)
            .map_err(|e| {
                e.to_string()
                    .trim()
                    .replace("\n\nFor more information, try '--help'.", "")
            })
    }
}

/// The model `generate KIND --ARG=VALUE ...` makes: `args` are its long
/// options without `--`, `_` for `-` (`tension_n`, `start_deg`), a value of
/// None a flag (`bay_by_bay`), as a sweep's `[base.args]` and the Python
/// package's `truss_deploy.generate` give them; the same defaults and checks.
pub fn generate_from_args(
    kind: &str,
    args: &[(String, Option<String>)],
) -> Result<model::ModelDoc, String> {
    let mut argv: Vec<String> = vec!["generate".into(), kind.into(), "-o".into(), "-".into()];
    for (k, v) in args {
        let flag = format!("--{}", k.replace('_', "-"));
        argv.push(match v {
            Some(v) => format!("{flag}={v}"),
            None => flag,
        });
    }
    let a = GenerateOnly::try_parse_from_args(&argv)?;
    generate_doc(&a).map_err(|f| f.message)
}

fn generate_cmd(a: GenerateArgs) -> Result<(), Failure> {
    output::check_outputs(&[], &[("-o", a.output.as_path())])?;
    let doc = generate_doc(&a)?;
    let text = doc.to_toml();
    // Written models must load: check before writing (nothing is written when
    // they do not; the options made them, so it is an input error).
    let kind = format!("{:?}", a.kind).to_lowercase();
    model::parse(&text, &format!("the model `generate {kind}` would write"))
        .map_err(|e| Failure::input(format!("{e}; nothing was written: change the options")))?;
    output::write_atomic(&a.output, text.as_bytes()).map_err(Failure::run)?;
    say!(
        "wrote {} ({} joints, {} elements)",
        a.output.display(),
        doc.joints.len(),
        doc.elements.len()
    );
    Ok(())
}

/// The model document `generate` makes of its arguments.
fn generate_doc(a: &GenerateArgs) -> Result<model::ModelDoc, Failure> {
    // (options of the ring alone: a mast or sail would silently ignore them)
    let ring_only = [
        ("--sync", a.sync.is_some()),
        ("--stow", a.stow),
        ("--bay-by-bay", a.bay_by_bay),
        ("--mount", a.mount.is_some()),
        ("--bus-mass-kg", a.bus_mass_kg.is_some()),
        ("--bus-inertia", a.bus_inertia.is_some()),
        ("--bus-offset-m", a.bus_offset_m.is_some()),
        ("--gear-stiffness", a.gear_stiffness.is_some()),
        ("--gear-damping", a.gear_damping.is_some()),
        ("--stroke-stops", a.stroke_stops.is_some()),
        ("--stroke-stop-damping", a.stroke_stop_damping.is_some()),
        ("--inner-chord-m", a.inner_chord_m.is_some()),
        ("--members", a.members.is_some()),
    ];
    if let (false, Some((name, _))) = (matches!(a.kind, Kind::Ring), ring_only.iter().find(|o| o.1))
    {
        return Err(Failure::input(format!(
            "{name} is an option of `generate ring`, not of `generate {}`",
            format!("{:?}", a.kind).to_lowercase()
        )));
    }
    Ok(match a.kind {
        Kind::Mast => {
            let d = generate::MastParams::default();
            let p = generate::MastParams {
                units: a.units,
                rod_length_m: a.rod_length_m.unwrap_or(d.rod_length_m),
                joint_mass_kg: a.joint_mass_kg.unwrap_or(d.joint_mass_kg),
                tension_n: a.tension_n.unwrap_or(d.tension_n),
                max_tension_n: d.max_tension_n.max(a.tension_n.unwrap_or(0.0)),
                friction_mu: a.mu.unwrap_or(d.friction_mu),
                damping_n_s_per_m: a.damping.unwrap_or(d.damping_n_s_per_m),
                start_deg: a.start_deg.unwrap_or(d.start_deg),
                deploy_deg: a.deploy_deg.unwrap_or(d.deploy_deg),
                latch: latch_option(&a)?,
                ..d
            };
            generate::mast(&p).map_err(Failure::input)?
        }
        Kind::Sail if a.latch_stiffness.is_some() || a.latch_damping.is_some() => {
            return Err(Failure::input(
                "--latch-stiffness/--latch-damping: the mast and the ring have compliant latches; \
                 the sail's are rigid",
            ));
        }
        Kind::Ring => {
            let bus = a.mount.as_deref() == Some("bus");
            if let Some(j) = a.bus_inertia.as_deref().filter(|j| j.len() != 3) {
                return Err(Failure::input(format!(
                    "--bus-inertia: give three principal inertias IXX,IYY,IZZ (kg m^2), got {}",
                    j.len()
                )));
            }
            if !bus
                && (a.bus_mass_kg.is_some() || a.bus_inertia.is_some() || a.bus_offset_m.is_some())
            {
                return Err(Failure::input(
                    "--bus-mass-kg, --bus-inertia and --bus-offset-m describe the bus of --mount bus; give --mount bus".to_string(),
                ));
            }
            if a.deploy_deg.is_some() {
                return Err(Failure::input(
                    "--deploy-deg: the ring has no deploy angle (it latches flat); \
                     --start-deg sets where it starts",
                ));
            }
            let d = if let Some(sync) = &a.sync {
                generate::ring::RingParams {
                    sync: sync.clone(),
                    ..generate::ring::RingParams::synchronized()
                }
            } else if a.stow {
                generate::ring::RingParams::stowing()
            } else {
                generate::ring::RingParams::bay_by_bay_sized(a.sides)
            };
            let p = generate::ring::RingParams {
                sides: a.sides,
                tension_n: a.tension_n.unwrap_or(d.tension_n),
                friction_mu: a.mu.unwrap_or(d.friction_mu),
                damping_n_s_per_m: a
                    .damping
                    .unwrap_or(if bus { 0.0 } else { d.damping_n_s_per_m }),
                bus: generate::ring::BusParams {
                    mass_kg: a.bus_mass_kg.unwrap_or(d.bus.mass_kg),
                    inertia_kg_m2: a
                        .bus_inertia
                        .as_deref()
                        .map_or(d.bus.inertia_kg_m2, |v| [v[0], v[1], v[2]]),
                    offset_m: a.bus_offset_m.unwrap_or(d.bus.offset_m),
                },
                mount: a.mount.clone().unwrap_or(d.mount.clone()),
                start_deg: a.start_deg.unwrap_or(d.start_deg),
                inner_chord_m: a.inner_chord_m.unwrap_or(d.inner_chord_m),
                latch: latch_option(&a)?,
                elastic_members: a
                    .members
                    .map_or(d.elastic_members, |m| m == MembersArg::Elastic),
                ..d
            };
            if let Some(ci) = a.inner_chord_m {
                if !(ci.is_finite() && ci > 0.0 && ci < p.outer_chord_m) {
                    return Err(Failure::input(format!(
                        "--inner-chord-m {ci}: give a length in metres between 0 and the outer chord, {} m",
                        p.outer_chord_m
                    )));
                }
            }
            let p = bay_by_bay_options(&a, p)?;
            generate::ring::ring(&p).map_err(Failure::input)?
        }
        Kind::Sail => {
            let d = generate::sail::SailParams::default();
            let p = generate::sail::SailParams {
                bays: a.bays,
                tension_n: a.tension_n.unwrap_or(d.tension_n),
                friction_mu: a.mu.unwrap_or(d.friction_mu),
                damping_n_s_per_m: a.damping.unwrap_or(d.damping_n_s_per_m),
                start_deg: a.start_deg.unwrap_or(d.start_deg),
                deploy_deg: a.deploy_deg.unwrap_or(d.deploy_deg),
                ..d
            };
            generate::sail::sail(&p).map_err(Failure::input)?
        }
    })
}

#[derive(Serialize)]
struct BenchJson {
    model: String,
    solver: String,
    steps: usize,
    us_per_step: f64,
    real_time_factor: f64,
    dt_s: f64,
    factorizations_per_step: f64,
}

/// Most steps `bench` times (8 bytes of timings each; ~5 min of the ring).
const MAX_BENCH_STEPS: usize = 1_000_000;

fn bench(a: BenchArgs) -> Result<(), Failure> {
    if !(1..=MAX_BENCH_STEPS).contains(&a.steps) {
        return Err(Failure::input(format!(
            "--steps {}: time 1 to {MAX_BENCH_STEPS} steps",
            a.steps
        )));
    }
    if let Some(j) = &a.json {
        output::check_outputs(&[a.model.as_path()], &[("--json", j.as_path())])?;
    }
    let mut sim = make_simulator(&a.model, a.solver.into())?;
    let dt = sim.model().dt_s;
    let mut times = Vec::with_capacity(a.steps);
    let f0 = sim.factorizations();
    for _ in 0..a.steps {
        if sim.state().deployed {
            sim.reset().map_err(|e| Failure::run(e.to_string()))?;
        }
        let t0 = Instant::now();
        sim.step(dt).map_err(|e| Failure::run(e.to_string()))?;
        times.push(t0.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    let out = BenchJson {
        model: sim.model().name.clone(),
        solver: format!("{:?}", a.solver).to_lowercase(),
        steps: a.steps,
        us_per_step: median * 1e6,
        real_time_factor: dt / median,
        dt_s: dt,
        factorizations_per_step: (sim.factorizations() - f0) as f64 / a.steps as f64,
    };
    say!(
        "{}: solver {}, {} steps, median {:.1} us/step, real-time factor {:.0} at dt {} s",
        out.model,
        out.solver,
        out.steps,
        out.us_per_step,
        out.real_time_factor,
        dt
    );
    let diag = sim.solver_diagnostics();
    if !diag.is_empty() {
        say!(
            "  solver: {diag}; {:.2} factor() calls per step",
            out.factorizations_per_step
        );
    }
    say!("  solver stats: {}", sim.solver_stats().line());
    if let Some(j) = &a.json {
        write_json(j, &out)?;
    }
    let _ = std::io::stdout().flush();
    Ok(())
}

#[cfg(feature = "ros")]
fn controller_cmd(a: crate::node::controller::ControllerArgs) -> Result<(), Failure> {
    use crate::node::controller;
    if let Some(path) = a.offline.clone() {
        let runs = controller::offline(&path, &a).map_err(Failure::input)?;
        for r in &runs {
            say!(
                "{:<28} deploy time {:>8} s  max latch impulse {:.6e} N s  sum {:.6e} N s  latch energy lost {:.6e} J",
                r.law,
                r.deploy_time_s.map_or("never".into(), |t| format!("{t:.3}")),
                r.max_impulse_ns,
                r.sum_impulse_ns,
                r.energy_lost_j
            );
        }
        return Ok(());
    }
    let r = controller::run_blocking(a).map_err(Failure::run)?;
    say!(
        "controller: {} states, {} commands, deployed {}, max latch impulse {:.6e} N s",
        r.states,
        r.commands,
        r.deployed,
        r.max_impulse_ns
    );
    Ok(())
}
