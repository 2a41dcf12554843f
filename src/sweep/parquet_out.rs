//! The rows as a Parquet file, written with parquet's own column writers (no
//! arrow): flat columns, and one LIST column per latch field. The schema is
//! documented in docs/sweeps.md.

use super::row::Row;
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::parser::parse_message_type;
use std::sync::Arc;

enum Vals {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Str(Vec<ByteArray>),
}

struct Col {
    schema: String,
    vals: Vals,
    def: Option<Vec<i16>>,
    rep: Option<Vec<i16>>,
}

fn req_f64(name: &str, v: Vec<f64>) -> Col {
    Col {
        schema: format!("required double {name};"),
        vals: Vals::F64(v),
        def: None,
        rep: None,
    }
}

/// An optional column: definition level 1 where a value is, 0 where null.
fn optional<T>(v: Vec<Option<T>>) -> (Vec<T>, Vec<i16>) {
    let def = v.iter().map(|x| x.is_some() as i16).collect();
    (v.into_iter().flatten().collect(), def)
}

fn opt_f64(name: &str, v: Vec<Option<f64>>) -> Col {
    let (vals, def) = optional(v);
    Col {
        schema: format!("optional double {name};"),
        vals: Vals::F64(vals),
        def: Some(def),
        rep: None,
    }
}

fn opt_i64(name: &str, v: Vec<Option<u64>>) -> Col {
    let (vals, def) = optional(v);
    Col {
        schema: format!("optional int64 {name};"),
        vals: Vals::I64(vals.into_iter().map(|x| x as i64).collect()),
        def: Some(def),
        rep: None,
    }
}

fn str_col(name: &str, v: Vec<Option<String>>, required: bool) -> Col {
    let (vals, def) = optional(v);
    Col {
        schema: format!(
            "{} binary {name} (UTF8);",
            if required { "required" } else { "optional" }
        ),
        vals: Vals::Str(
            vals.into_iter()
                .map(|s| ByteArray::from(s.as_str()))
                .collect(),
        ),
        def: (!required).then_some(def),
        rep: None,
    }
}

/// A LIST column (never null itself): per row, its elements; `Some` values
/// are present, `None` null elements (only when `nullable`).
fn list_col<T>(
    name: &str,
    elem: &str,
    nullable: bool,
    rows: Vec<Vec<Option<T>>>,
    wrap: fn(Vec<T>) -> Vals,
) -> Col {
    let (mut vals, mut def, mut rep) = (Vec::new(), Vec::new(), Vec::new());
    for r in rows {
        if r.is_empty() {
            def.push(0);
            rep.push(0);
        }
        for (i, v) in r.into_iter().enumerate() {
            rep.push(if i == 0 { 0 } else { 1 });
            match v {
                Some(x) => {
                    def.push(if nullable { 2 } else { 1 });
                    vals.push(x);
                }
                None => def.push(1),
            }
        }
    }
    Col {
        schema: format!(
            "required group {name} (LIST) {{ repeated group list {{ {} {elem} element; }} }}",
            if nullable { "optional" } else { "required" }
        ),
        vals: wrap(vals),
        def: Some(def),
        rep: Some(rep),
    }
}

/// The Parquet file of `rows` (in index order) as bytes. `columns` name the
/// parameters; `metadata` goes into the file's key-value metadata.
pub fn to_parquet(
    rows: &[Row],
    columns: &[String],
    metadata: &[(String, String)],
) -> Result<Vec<u8>, String> {
    let f = |g: fn(&Row) -> Option<f64>| rows.iter().map(g).collect::<Vec<_>>();
    let u = |g: fn(&Row) -> Option<u64>| rows.iter().map(g).collect::<Vec<_>>();
    let mut cols = vec![
        Col {
            schema: "required int64 index;".into(),
            vals: Vals::I64(rows.iter().map(|r| r.index as i64).collect()),
            def: None,
            rep: None,
        },
        Col {
            schema: "required int64 seed (INTEGER(64,false));".into(),
            // (the bits of the u64; readers show it unsigned)
            vals: Vals::I64(rows.iter().map(|r| r.seed as i64).collect()),
            def: None,
            rep: None,
        },
    ];
    for (i, c) in columns.iter().enumerate() {
        cols.push(req_f64(c, rows.iter().map(|r| r.params[i]).collect()));
    }
    cols.push(str_col(
        "stop_reason",
        rows.iter().map(|r| Some(r.stop_reason.clone())).collect(),
        true,
    ));
    cols.push(str_col(
        "stop_message",
        rows.iter().map(|r| Some(r.stop_message.clone())).collect(),
        true,
    ));
    cols.push(Col {
        schema: "required boolean deployed;".into(),
        vals: Vals::Bool(rows.iter().map(|r| r.deployed).collect()),
        def: None,
        rep: None,
    });
    cols.push(opt_f64("deploy_time_s", f(|r| r.deploy_time_s)));
    cols.push(opt_f64("time_s", f(|r| r.time_s)));
    cols.push(opt_i64("steps", u(|r| r.steps)));
    cols.push(req_f64(
        "wall_time_s",
        rows.iter().map(|r| r.wall_time_s).collect(),
    ));
    cols.push(opt_f64("final_error_rel", f(|r| r.final_error_rel)));
    cols.push(opt_f64(
        "max_constraint_violation_m",
        f(|r| r.max_constraint_violation_m),
    ));
    cols.push(opt_f64(
        "energy_balance_rel_error",
        f(|r| r.energy_balance_rel_error),
    ));
    cols.push(opt_f64("kinetic_energy_j", f(|r| r.kinetic_energy_j)));
    cols.push(opt_f64("motor_work_j", f(|r| r.motor_work_j)));
    cols.push(opt_f64("friction_loss_j", f(|r| r.friction_loss_j)));
    cols.push(opt_f64("damping_loss_j", f(|r| r.damping_loss_j)));
    cols.push(opt_f64("lock_loss_j", f(|r| r.lock_loss_j)));
    cols.push(opt_f64(
        "latch_damping_loss_j",
        f(|r| r.latch_damping_loss_j),
    ));
    cols.push(opt_i64("substeps", u(|r| r.substeps)));
    cols.push(opt_i64("newmark_iterations", u(|r| r.newmark_iterations)));
    cols.push(opt_i64("factorizations", u(|r| r.factorizations)));
    cols.push(opt_i64("solves", u(|r| r.solves)));
    cols.push(opt_i64("substep_halvings", u(|r| r.substep_halvings)));
    cols.push(opt_i64("solve_unconverged", u(|r| r.solve_unconverged)));
    cols.push(opt_i64("accepting_fallbacks", u(|r| r.accepting_fallbacks)));
    cols.push(list_col(
        "latch_name",
        "binary",
        false,
        rows.iter()
            .map(|r| {
                r.latches
                    .iter()
                    .map(|l| Some(ByteArray::from(l.name.as_str())))
                    .collect()
            })
            .collect(),
        Vals::Str,
    ));
    // (the element of latch_name is UTF8: patch its schema line)
    if let Some(c) = cols.last_mut() {
        c.schema = c
            .schema
            .replace("binary element;", "binary element (UTF8);");
    }
    type LatchField = fn(&super::row::LatchRow) -> Option<f64>;
    let fields: [(&str, bool, LatchField); 5] = [
        ("latch_time_s", false, |l| Some(l.time_s)),
        ("latch_impulse_ns", false, |l| Some(l.impulse_ns)),
        ("latch_energy_lost_j", false, |l| Some(l.energy_lost_j)),
        ("latch_peak_force_n", true, |l| l.peak_force_n),
        ("latch_time_of_peak_s", true, |l| l.time_of_peak_s),
    ];
    for (name, nullable, g) in fields {
        cols.push(list_col(
            name,
            "double",
            nullable,
            rows.iter()
                .map(|r| r.latches.iter().map(g).collect())
                .collect(),
            Vals::F64,
        ));
    }
    cols.push(opt_f64(
        "max_latch_impulse_ns",
        f(|r| r.max_latch_impulse_ns),
    ));
    cols.push(opt_f64(
        "max_latch_peak_force_n",
        f(|r| r.max_latch_peak_force_n),
    ));
    cols.push(str_col(
        "last_latch",
        rows.iter().map(|r| r.last_latch.clone()).collect(),
        false,
    ));
    cols.push(opt_f64("first_frequency_hz", f(|r| r.first_frequency_hz)));
    cols.push(opt_f64("bus_peak_rate_rad_s", f(|r| r.bus_peak_rate_rad_s)));
    cols.push(opt_f64(
        "bus_attitude_change_deg",
        f(|r| r.bus_attitude_change_deg),
    ));
    cols.push(opt_f64(
        "angular_momentum_drift_rel",
        f(|r| r.angular_momentum_drift_rel),
    ));
    let message = format!(
        "message sweep {{ {} }}",
        cols.iter()
            .map(|c| c.schema.as_str())
            .collect::<Vec<_>>()
            .join(" ")
    );
    let e = |e: parquet::errors::ParquetError| format!("cannot write the Parquet file: {e}");
    let schema = Arc::new(parse_message_type(&message).map_err(e)?);
    let props = WriterProperties::builder()
        .set_key_value_metadata(Some(
            metadata
                .iter()
                .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
                .collect(),
        ))
        .build();
    let mut out = Vec::new();
    let mut w = SerializedFileWriter::new(&mut out, schema, Arc::new(props)).map_err(e)?;
    let mut rg = w.next_row_group().map_err(e)?;
    for c in &cols {
        let mut cw = rg
            .next_column()
            .map_err(e)?
            .ok_or("the Parquet schema has fewer columns than the rows")?;
        let (d, r) = (c.def.as_deref(), c.rep.as_deref());
        match &c.vals {
            Vals::F64(v) => cw.typed::<DoubleType>().write_batch(v, d, r),
            Vals::I64(v) => cw.typed::<Int64Type>().write_batch(v, d, r),
            Vals::Bool(v) => cw.typed::<BoolType>().write_batch(v, d, r),
            Vals::Str(v) => cw.typed::<ByteArrayType>().write_batch(v, d, r),
        }
        .map_err(e)?;
        cw.close().map_err(e)?;
    }
    rg.close().map_err(e)?;
    w.close().map_err(e)?;
    Ok(out)
}
