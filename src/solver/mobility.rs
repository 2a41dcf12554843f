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

/// Singular values of A below this fraction of the largest (and above the
/// rank decision's `RANK_TOL`) are a nearly singular configuration: rows
/// that are independent, but barely (`near_dependence`).
pub const NEAR_SINGULAR_REL: f64 = 1e-5;

/// How nearly dependent the constraint rows of a state are
/// (`near_dependence`): the rank, and the directions in which the rows
/// are independent only by a small singular value, with the elements whose
/// rows carry them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NearDependence {
    pub coordinates: usize,
    pub rows: usize,
    pub rank: usize,
    /// Rows less rank: states of self-stress (exactly redundant rows).
    pub self_stress: usize,
    /// The smallest singular values above `RANK_TOL` and at most
    /// `NEAR_SINGULAR_REL` of the largest, smallest first, each with the
    /// elements carrying most of its left singular vector (their share of
    /// its squared norm, largest first, at most six).
    pub near: Vec<NearDirection>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NearDirection {
    pub sigma_rel: f64,
    pub elements: Vec<(String, f64)>,
}

/// The near dependence of the rows of `jac` (filled at the state) by a
/// dense SVD.
pub fn near_dependence(model: &Model, jac: &Jacobian) -> NearDependence {
    let (m, n) = (jac.nrows, jac.ncols);
    let mut out = NearDependence {
        coordinates: n,
        rows: m,
        rank: 0,
        self_stress: 0,
        near: Vec::new(),
    };
    if m == 0 {
        return out;
    }
    let svd = jac.to_dense().svd(true, false);
    let u = svd.u.expect("u requested");
    let sigma = svd.singular_values;
    let smax = sigma.iter().cloned().fold(0.0, f64::max);
    out.rank = super::rank::numerical_rank(sigma.as_slice());
    out.self_stress = m - out.rank;
    let mut near: Vec<usize> = (0..sigma.len())
        .filter(|&k| sigma[k] > RANK_TOL * smax && sigma[k] <= NEAR_SINGULAR_REL * smax)
        .collect();
    near.sort_by(|&a, &b| sigma[a].total_cmp(&sigma[b]));
    for &k in near.iter().take(3) {
        let mut share: Vec<(usize, f64)> = Vec::new();
        for row in 0..m {
            let (e, _) = jac.row_owner(row);
            let w = u[(row, k)].powi(2);
            match share.iter_mut().find(|s| s.0 == e) {
                Some(s) => s.1 += w,
                None => share.push((e, w)),
            }
        }
        share.sort_by(|a, b| b.1.total_cmp(&a.1));
        out.near.push(NearDirection {
            sigma_rel: sigma[k] / smax,
            elements: share
                .into_iter()
                .take(6)
                .map(|(e, w)| (model.elements[e].name().to_string(), w))
                .collect(),
        });
    }
    out
}

impl std::fmt::Display for NearDependence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Some(first) = self.near.first() else {
            return write!(
                f,
                "the constraint rows are not nearly dependent there (rank {} of {} rows, {} coordinates; \
                 no singular value between {RANK_TOL:e} and {NEAR_SINGULAR_REL:e} of the largest)",
                self.rank, self.rows, self.coordinates
            );
        };
        let names: Vec<String> = first
            .elements
            .iter()
            .map(|(name, w)| format!("`{name}` ({:.0} %)", 100.0 * w))
            .collect();
        write!(
            f,
            "the constraint rows are nearly dependent there: {} singular value(s) of the Jacobian \
             between {RANK_TOL:e} and {NEAR_SINGULAR_REL:e} of the largest, the smallest {:.1e}, \
             its rows mostly those of {} (rank {} of {} rows, {} coordinates, {} states of \
             self-stress): a singular configuration, which rigid members cannot cross (their \
             solves stop converging; a shorter step does not help, docs/solver.md); make the \
             members elastic ([solver] elastic_members = true, or `truss-deploy generate ring \
             --members elastic`)",
            self.near.len(),
            first.sigma_rel,
            names.join(", "),
            self.rank,
            self.rows,
            self.coordinates,
            self.self_stress
        )
    }
}
