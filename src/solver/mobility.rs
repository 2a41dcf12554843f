//! Mobility of the constraint set: rank of A, mechanisms m = 3n - rank A, states of
//! self-stress s = rows - rank A (so that m - s = 3n - rows, the extended Maxwell
//! rule of Calladine and Pellegrino), and which rows are redundant.

use super::jacobian::Jacobian;
use super::model::Model;
use serde::Serialize;

pub use super::rank::RANK_TOL;

#[derive(Clone, Debug, Serialize)]
pub struct ElementRows {
    pub kind: String,
    pub elements: usize,
    pub rows: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Mobility {
    pub coordinates: usize,
    pub rows: usize,
    pub rank: usize,
    pub mechanisms: usize,
    pub self_stress: usize,
    /// Rows that depend on earlier rows, as "element:row".
    pub redundant_rows: Vec<String>,
    pub per_element: Vec<ElementRows>,
}

/// Numerical rank of A by SVD (the one decision: [`super::rank`]).
pub fn rank(jac: &Jacobian) -> usize {
    super::rank::of_jacobian(jac)
}

/// The locked sets of `analyze`: the lockable elements already at their lock
/// (within `lock_tol_m`) in the initial geometry, and every lockable element.
pub fn lock_sets(model: &Model) -> (Vec<bool>, Vec<bool>) {
    let x0 = &model.x0;
    let at_start = model
        .elements
        .iter()
        .map(|e| {
            e.lock_gap(x0)
                .is_some_and(|g| g.abs() <= model.solver.lock_tol_m)
        })
        .collect();
    let all = model
        .elements
        .iter()
        .map(|e| e.lock_gap(x0).is_some())
        .collect();
    (at_start, all)
}

/// Mobility before the latches (the initial geometry, the elements already
/// at their lock locked) and with every lockable element locked (at the
/// reference geometry, or the initial one without it): what `analyze`
/// reports.
pub fn before_and_after_locks(model: &Model) -> (Mobility, Mobility) {
    let (at_start, all) = lock_sets(model);
    let xl = model.reference.as_deref().unwrap_or(model.x0.as_slice());
    (
        analyze(model, &model.x0, &at_start),
        analyze(model, xl, &all),
    )
}

/// Mobility of `model` at positions `x` with the given locked set.
pub fn analyze(model: &Model, x: &[f64], locked: &[bool]) -> Mobility {
    let mut jac = Jacobian::pattern(model, locked);
    jac.fill(model, x);
    let r = rank(&jac);
    let dense = jac.to_dense();
    // Greedy row selection with a Gram-Schmidt basis: a row is redundant if it
    // lies (to ROW_SINE_TOL) in the span of the rows before it.
    let mut basis: Vec<nalgebra::DVector<f64>> = Vec::new();
    let mut redundant = Vec::new();
    for row in 0..jac.nrows {
        let mut w = dense.row(row).transpose();
        let norm0 = w.norm();
        for _ in 0..2 {
            for q in &basis {
                let p = q.dot(&w);
                w.axpy(-p, q, 1.0);
            }
        }
        if !super::rank::row_is_redundant(w.norm_squared() / norm0.max(1e-300).powi(2)) {
            basis.push(w.normalize());
        } else {
            let (e, local) = jac.row_owner(row);
            redundant.push(format!("{}:{}", model.elements[e].name(), local));
        }
    }
    let mut per_element: Vec<ElementRows> = Vec::new();
    for (e, el) in model.elements.iter().enumerate() {
        let rows = el.rows(locked[e]);
        match per_element.iter_mut().find(|p| p.kind == el.kind()) {
            Some(p) => {
                p.elements += 1;
                p.rows += rows;
            }
            None => per_element.push(ElementRows {
                kind: el.kind().to_string(),
                elements: 1,
                rows,
            }),
        }
    }
    Mobility {
        coordinates: model.n_coords(),
        rows: jac.nrows,
        rank: r,
        mechanisms: model.n_coords() - r,
        self_stress: jac.nrows - r,
        redundant_rows: redundant,
        per_element,
    }
}
