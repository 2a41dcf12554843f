//! A run's history as Parquet tables (`simulate --history DIR`, a sweep's
//! `[sweep] history`): `joints.parquet`, `members.parquet`,
//! `cables.parquet`, `latches.parquet`, `energy.parquet`, `bodies.parquet`, one row per
//! recorded step in each (the first state, every `every`-th step, the last),
//! wide: columns `step`, `t_s`, then `<name>.<quantity>_<unit>` per joint,
//! member, cable or latch. The schema is documented in docs/cli.md
//! ("Histories"). Written with parquet's own column writers (as the sweep's
//! rows), each table to a temporary sibling renamed onto its path when the
//! run ends.

use parquet::basic::{ConvertedType, LogicalType, Repetition, Type as PhysicalType};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use truss_deploy_core::files::AtomicFile;
use truss_deploy_core::record::{Frame, FrameLayout, LatchState, RecordError, Recorder, Thinning};
use truss_deploy_core::run::Stop;
use truss_deploy_core::solver::state::MotorHold;
use truss_deploy_core::solver::Simulator;

/// The history's tables, in the order they are written.
pub const TABLES: [&str; 6] = ["joints", "members", "cables", "latches", "energy", "bodies"];

/// The file of `table` in the history directory `dir`.
pub fn table_path(dir: &Path, table: &str) -> PathBuf {
    dir.join(format!("{table}.parquet"))
}

/// A column's quantity suffix and the empty values it starts from.
type Quantity<'a> = (&'a str, fn() -> Vals);

enum Vals {
    F64(Vec<f64>),
    OptF64(Vec<Option<f64>>),
    I64(Vec<i64>),
    Str(Vec<&'static str>),
}

struct Col {
    name: String,
    vals: Vals,
}

/// One table's columns, filled a row (a frame) at a time.
struct Table {
    cols: Vec<Col>,
    metadata: Vec<(String, String)>,
}

impl Table {
    fn new(names: Vec<(String, fn() -> Vals)>) -> Table {
        let mut cols = vec![
            Col {
                name: "step".into(),
                vals: Vals::I64(Vec::new()),
            },
            Col {
                name: "t_s".into(),
                vals: Vals::F64(Vec::new()),
            },
        ];
        cols.extend(names.into_iter().map(|(name, v)| Col { name, vals: v() }));
        Table {
            cols,
            metadata: Vec::new(),
        }
    }
    fn rows(&self) -> usize {
        match &self.cols[0].vals {
            Vals::I64(v) => v.len(),
            _ => 0,
        }
    }
}

fn f64s() -> Vals {
    Vals::F64(Vec::new())
}
fn opt_f64s() -> Vals {
    Vals::OptF64(Vec::new())
}
fn strs() -> Vals {
    Vals::Str(Vec::new())
}

/// A row's values in column order after `step` and `t_s`.
enum V {
    F(f64),
    O(Option<f64>),
    S(&'static str),
}

fn push(t: &mut Table, f: &Frame, vals: impl IntoIterator<Item = V>) {
    if let Vals::I64(v) = &mut t.cols[0].vals {
        v.push(f.step as i64);
    }
    if let Vals::F64(v) = &mut t.cols[1].vals {
        v.push(f.t_s);
    }
    let mut n = 2;
    for (col, val) in t.cols[2..].iter_mut().zip(vals) {
        match (&mut col.vals, val) {
            (Vals::F64(v), V::F(x)) => v.push(x),
            (Vals::OptF64(v), V::O(x)) => v.push(x),
            (Vals::Str(v), V::S(x)) => v.push(x),
            _ => unreachable!("a history column gets a value of its own type"),
        }
        n += 1;
    }
    debug_assert_eq!(n, t.cols.len());
}

/// The motor's mode as in the JSON summary's `motors`.
pub fn motor_mode_label(h: MotorHold) -> &'static str {
    match h {
        MotorHold::Tension => "tension",
        MotorHold::Tracking => "tracking",
        MotorHold::AtLimit => "at_limit",
        MotorHold::Slack => "slack",
    }
}

pub fn latch_state_label(s: LatchState) -> &'static str {
    match s {
        LatchState::Open => "open",
        LatchState::Latched => "latched",
        LatchState::Engaging => "engaging",
    }
}

/// The energy columns: the ledger's terms (J) as in the JSON summary's
/// `energy`, the kinetic energy and the balance's relative error.
const ENERGY: [&str; 14] = [
    "motor_work_j",
    "cable_work_j",
    "friction_loss_j",
    "damping_loss_j",
    "lock_loss_j",
    "gravity_work_j",
    "latch_damping_loss_j",
    "latch_spring_energy_j",
    "element_spring_energy_j",
    "member_strain_energy_j",
    "member_damping_loss_j",
    "integrator_work_j",
    "kinetic_energy_j",
    "balance_rel_error",
];

fn energy_values(f: &Frame) -> [f64; 14] {
    let e = &f.energy;
    [
        e.motor_work_j,
        e.cable_work_j,
        e.friction_loss_j,
        e.damping_loss_j,
        e.lock_loss_j,
        e.gravity_work_j,
        e.latch_damping_loss_j,
        e.latch_spring_energy_j,
        e.element_spring_energy_j,
        e.member_strain_energy_j,
        e.member_damping_loss_j,
        e.integrator_work_j,
        f.kinetic_energy_j,
        f.balance_rel_error,
    ]
}

/// The six tables of a history being recorded, kept in memory until the
/// run ends.
pub struct History {
    layout: FrameLayout,
    tables: [Table; 6],
}

impl History {
    pub fn new(layout: FrameLayout, model_name: &str) -> History {
        let per = |names: &[String], q: &[Quantity]| {
            names
                .iter()
                .flat_map(|n| q.iter().map(move |(s, v)| (format!("{n}.{s}"), *v)))
                .collect::<Vec<_>>()
        };
        let joints = per(
            &layout.joints,
            &[
                ("x_m", f64s),
                ("y_m", f64s),
                ("z_m", f64s),
                ("vx_m_s", f64s),
                ("vy_m_s", f64s),
                ("vz_m_s", f64s),
            ],
        );
        let member_names: Vec<String> = layout.members.iter().map(|m| m.name.clone()).collect();
        let members = per(&member_names, &[("force_n", f64s), ("length_m", f64s)]);
        let mut cables = Vec::new();
        for c in &layout.cables {
            for k in 0..c.segments {
                cables.push((
                    format!("{}.segment{k}_tension_n", c.name),
                    f64s as fn() -> Vals,
                ));
            }
            cables.push((format!("{}.length_m", c.name), f64s));
            cables.push((format!("{}.reeled_in_m", c.name), f64s));
            cables.push((format!("{}.motor_mode", c.name), strs));
        }
        let latch_names: Vec<String> = layout.latches.iter().map(|l| l.name.clone()).collect();
        let latches = per(
            &latch_names,
            &[
                ("gap_m", f64s),
                ("state", strs),
                ("force_n", f64s),
                ("peak_force_n", opt_f64s),
                ("time_of_peak_s", opt_f64s),
            ],
        );
        let energy = ENERGY
            .iter()
            .map(|n| (n.to_string(), f64s as fn() -> Vals))
            .collect();
        let mut bodies = per(
            &layout.bodies.names(),
            &[("attitude_change_deg", f64s), ("rate_rad_s", f64s)],
        );
        for (q, unit) in [("linear_momentum", "n_s"), ("angular_momentum", "n_m_s")] {
            for c in ["x", "y", "z"] {
                bodies.push((format!("{q}_{c}_{unit}"), f64s as fn() -> Vals));
            }
        }
        let mut tables = [
            Table::new(joints),
            Table::new(members),
            Table::new(cables),
            Table::new(latches),
            Table::new(energy),
            Table::new(bodies),
        ];
        // (what a reader needs beside the columns: the model, each joint's
        // mass, each member's kind and end joints)
        let layout_json = serde_json::json!({
            "model": model_name,
            "joints": layout.joints.iter().zip(&layout.joint_mass_kg)
                .map(|(n, m)| serde_json::json!({"name": n, "mass_kg": m}))
                .collect::<Vec<_>>(),
            "members": layout.members.iter().map(|m| serde_json::json!({
                "name": m.name,
                "kind": m.kind.label(),
                "joints": [layout.joints[m.joints[0]], layout.joints[m.joints[1]]],
            })).collect::<Vec<_>>(),
        })
        .to_string();
        for t in &mut tables {
            t.metadata = vec![
                ("truss_deploy.model".into(), model_name.to_string()),
                ("truss_deploy.layout".into(), layout_json.clone()),
            ];
        }
        History { layout, tables }
    }

    /// Rows recorded so far (the same in every table).
    pub fn rows(&self) -> usize {
        self.tables[0].rows()
    }

    /// The last recorded step, if any.
    fn last_step(&self) -> Option<i64> {
        match &self.tables[0].cols[0].vals {
            Vals::I64(v) => v.last().copied(),
            _ => None,
        }
    }

    pub fn push(&mut self, f: &Frame) {
        let [joints, members, cables, latches, energy, bodies] = &mut self.tables;
        push(
            joints,
            f,
            (0..self.layout.joints.len()).flat_map(|j| {
                (0..3)
                    .map(move |k| V::F(f.x[3 * j + k]))
                    .chain((0..3).map(move |k| V::F(f.v[3 * j + k])))
            }),
        );
        push(
            members,
            f,
            f.member_force_n
                .iter()
                .zip(&f.member_length_m)
                .flat_map(|(&t, &l)| [V::F(t), V::F(l)]),
        );
        push(
            cables,
            f,
            self.layout.cables.iter().enumerate().flat_map(|(c, info)| {
                // (as many values as the layout's segments, whatever the
                // evaluation holds: NaN for one it lacks)
                (0..info.segments)
                    .map(move |k| V::F(f.cable_tension_n[c].get(k).copied().unwrap_or(f64::NAN)))
                    .chain([
                        V::F(f.cable_length_m[c]),
                        V::F(f.reeled_in_m[c]),
                        V::S(motor_mode_label(f.motor_mode[c])),
                    ])
            }),
        );
        push(
            latches,
            f,
            (0..self.layout.latches.len()).flat_map(|l| {
                [
                    V::F(f.latch_gap_m[l]),
                    V::S(latch_state_label(f.latch_state[l])),
                    V::F(f.latch_force_n[l]),
                    V::O(f.latch_peak_force_n[l]),
                    V::O(f.latch_time_of_peak_s[l]),
                ]
            }),
        );
        push(energy, f, energy_values(f).map(V::F));
        let b = &f.bodies;
        push(
            bodies,
            f,
            b.bodies
                .iter()
                .flat_map(|&(rate, angle, _)| [V::F(angle.to_degrees()), V::F(rate)])
                .chain(
                    b.linear_n_s
                        .iter()
                        .chain(&b.angular_n_m_s)
                        .map(|&v| V::F(v)),
                ),
        );
    }

    /// The Parquet file of table `i` (in [`TABLES`] order) as bytes.
    pub fn to_parquet(&self, i: usize) -> Result<Vec<u8>, parquet::errors::ParquetError> {
        let t = &self.tables[i];
        let fields = t
            .cols
            .iter()
            .map(|c| {
                let (ty, rep) = match c.vals {
                    Vals::F64(_) => (PhysicalType::DOUBLE, Repetition::REQUIRED),
                    Vals::OptF64(_) => (PhysicalType::DOUBLE, Repetition::OPTIONAL),
                    Vals::I64(_) => (PhysicalType::INT64, Repetition::REQUIRED),
                    Vals::Str(_) => (PhysicalType::BYTE_ARRAY, Repetition::REQUIRED),
                };
                let mut b = Type::primitive_type_builder(&c.name, ty).with_repetition(rep);
                if matches!(c.vals, Vals::Str(_)) {
                    b = b
                        .with_logical_type(Some(LogicalType::String))
                        .with_converted_type(ConvertedType::UTF8);
                }
                b.build().map(Arc::new)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let schema = Arc::new(
            Type::group_type_builder(TABLES[i])
                .with_fields(fields)
                .build()?,
        );
        let props = WriterProperties::builder()
            .set_key_value_metadata(Some(
                t.metadata
                    .iter()
                    .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
                    .collect(),
            ))
            .build();
        let mut out = Vec::new();
        let mut w = SerializedFileWriter::new(&mut out, schema, Arc::new(props))?;
        let mut rg = w.next_row_group()?;
        for c in &t.cols {
            let Some(mut cw) = rg.next_column()? else {
                break;
            };
            match &c.vals {
                Vals::F64(v) => cw.typed::<DoubleType>().write_batch(v, None, None)?,
                Vals::I64(v) => cw.typed::<Int64Type>().write_batch(v, None, None)?,
                Vals::OptF64(v) => {
                    let def: Vec<i16> = v.iter().map(|x| x.is_some() as i16).collect();
                    let vals: Vec<f64> = v.iter().flatten().copied().collect();
                    cw.typed::<DoubleType>()
                        .write_batch(&vals, Some(&def), None)?
                }
                Vals::Str(v) => {
                    let vals: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(*s)).collect();
                    cw.typed::<ByteArrayType>().write_batch(&vals, None, None)?
                }
            };
            cw.close()?;
        }
        rg.close()?;
        w.close()?;
        Ok(out)
    }

    /// Writes the six tables into `dir`, each atomically. `output` names
    /// the option or key in errors.
    pub fn write(&self, dir: &Path, output: &'static str) -> Result<(), RecordError> {
        for (i, table) in TABLES.iter().enumerate() {
            let path = table_path(dir, table);
            let bytes = self
                .to_parquet(i)
                .map_err(|e| RecordError::other(output, &path, e.to_string()))?;
            let mut f = AtomicFile::open(&path).map_err(|e| RecordError::io(output, &path, e))?;
            std::io::Write::write_all(f.writer(), &bytes)
                .map_err(|e| RecordError::io(output, &path, e))?;
            f.commit_io()
                .map_err(|e| RecordError::io(output, &path, e))?;
        }
        Ok(())
    }
}

/// The recorder of a history: a frame of the first state, of every
/// `thin.every`-th step and of the last, written into `dir` at the end.
pub struct HistoryRecorder {
    dir: PathBuf,
    output: &'static str,
    thin: Thinning,
    history: History,
}

impl HistoryRecorder {
    pub fn new(
        sim: &Simulator,
        dir: &Path,
        output: &'static str,
        thin: Thinning,
    ) -> HistoryRecorder {
        let layout = FrameLayout::new(sim.model());
        HistoryRecorder {
            dir: dir.to_path_buf(),
            output,
            thin,
            history: History::new(layout, &sim.model().name),
        }
    }

    fn record(&mut self, sim: &mut Simulator) {
        let f = Frame::capture(&self.history.layout, sim);
        self.history.push(&f);
    }
}

impl Recorder for HistoryRecorder {
    fn start(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        self.record(sim);
        Ok(())
    }
    fn after_step(&mut self, sim: &mut Simulator) -> Result<(), RecordError> {
        if self.thin.keeps(sim.state().steps) {
            self.record(sim);
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulator, _stop: &Stop) -> Result<(), RecordError> {
        if self.history.last_step() != Some(sim.state().steps as i64) {
            self.record(sim);
        }
        self.history.write(&self.dir, self.output)
    }
}
