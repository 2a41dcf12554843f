//! The smallest singular values of a model's constraint Jacobian A at its
//! initial state (every sleeve that starts at its lock latched), relative to
//! the largest, with the element rows and joint coordinates each one's
//! singular vectors weigh most: where a configuration is close to losing
//! rank (e.g. a ring near its flat deployed state, docs/double_ring_stowing.md,
//! "The 36-sided ring's endgame is a near-singular configuration"). Start it from a run's state with
//! docs/double_ring_variants/restart_from_csv.py.
//!
//!     cargo run --release --example near_singular -- MODEL.toml [COUNT]

use truss_deploy::solver::jacobian::Jacobian;
use truss_deploy::solver::{Options, Simulator};

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: near_singular MODEL.toml [COUNT]")?;
    let count: usize = match args.next() {
        Some(c) => c
            .parse()
            .map_err(|_| format!("COUNT `{c}`: give a whole number"))?,
        None => 12,
    };
    let load = || {
        truss_deploy::model::load(std::path::Path::new(&path))
            .map(|l| l.model)
            .map_err(|e| e.to_string())
    };
    let model = load()?;
    let sim = Simulator::new(load()?, Options::default()).map_err(|e| e.to_string())?;
    let state = sim.state();
    let mut jac = Jacobian::pattern(&model, &state.locked);
    jac.fill(&model, &state.x);
    let a = jac.to_dense();
    let svd = a.clone().svd(true, true);
    let (u, v_t) = (svd.u.ok_or("no U")?, svd.v_t.ok_or("no V")?);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let smax = svd.singular_values.max();
    println!(
        "{} rows, {} coordinates, {} sleeves latched; sigma_max {smax:.4e}",
        a.nrows(),
        a.ncols(),
        state.locked.iter().filter(|&&l| l).count()
    );
    // below the rank decision (crate::solver::rank) a direction is a
    // mechanism or a state of self-stress, not a near-singular one
    let above = order
        .iter()
        .filter(|&&i| svd.singular_values[i] > truss_deploy::solver::rank::RANK_TOL * smax);
    for &i in above.take(count) {
        let top = |w: Vec<(f64, String)>| {
            let mut w = w;
            w.sort_by(|a, b| b.0.total_cmp(&a.0));
            w.iter()
                .take(6)
                .map(|(x, n)| format!("{n} {x:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let rows = (0..a.nrows())
            .map(|r| {
                let (e, k) = jac.row_owner(r);
                (u[(r, i)].abs(), format!("{}:{k}", model.elements[e].name()))
            })
            .collect();
        let cols = (0..a.ncols())
            .map(|c| {
                let axis = ["x", "y", "z"][c % 3];
                (
                    v_t[(i, c)].abs(),
                    format!("{}_{axis}", model.joints[c / 3].name),
                )
            })
            .collect();
        println!(
            "sigma/sigma_max {:.3e}\n  rows   {}\n  joints {}",
            svd.singular_values[i] / smax,
            top(rows),
            top(cols)
        );
    }
    Ok(())
}
