//! Natural frequencies and mode shapes of a truss, linearized about a state
//! on the tangent space of its rigid rows.
//!
//! The equations of motion M Xddot = Q(X) + A^T lambda (M the lumped joint
//! masses) linearized about a state X* with multipliers lambda* and cable
//! tensions T* give, for small motions u on the tangent space of the rigid
//! rows (A_r u = 0),
//!
//!   M uddot + K u = A_r^T dlambda_r,
//!   K = A_m^T C^-1 A_m + A_s^T k A_s + K_g,
//!   K_g = - sum_i lambda*_i H_i + sum_s k Phi_s H_s + sum_j T*_j (I - e_j e_j^T) / l_j,
//!
//! with
//! - A_m the member rows (bars, latched sleeves, the members of scissors and
//!   plates), C their compliances L/EA (plus 1/k of a compliant latch, in
//!   series with its tube): members are elastic here whether or not the run
//!   takes them so (`elastic_members`); the rows that are not members
//!   (supports, pivots, hinges, coplanarity, gears' rigid parts) are rigid;
//! - A_s the rows of the compliant elements (gears, end stops in contact),
//!   stiffness k, residual Phi_s;
//! - H_i = d^2 Phi_i / dX^2 the Hessian of row i, taken exactly from the
//!   element's velocity-product term: (Adot Xdot)_i = v^T H_i v at Xdot = v,
//!   so by polarization H_jk = 1/2 (q(e_j + e_k) - q(e_j) - q(e_k));
//! - the cable's straight segments j between pulleys, each pulling its two
//!   joints together with tension T*_j: the geometric stiffness of a string.
//!
//! lambda* is the least-work split (`crate::solver::least_work`) of the
//! joint forces the rows carry: -Q(X*) at a deployed equilibrium, A^T lambda
//! of a saved state otherwise. With a mass-scaled null-space basis N of
//! A_r M^-1/2 (an SVD: redundant rigid rows need no care) the problem is
//! the symmetric eigenproblem (N^T M^-1/2 K M^-1/2 N) z = omega^2 z, and the
//! mode shape is u = M^-1/2 N z.
//!
//! Omega^2 of at most `modes_mechanism_rel` of the largest eigenvalue is a
//! mechanism (a motion that neither strains a member nor works against a
//! preload); a negative one beyond it is an instability (compression).

use super::elements::Constraint;
use super::jacobian::Jacobian;
use super::least_work::LeastWork;
use super::linsolve::SolverKind;
use super::model::Model;
use super::state::State;
use super::SolverError;
use serde::Serialize;
use std::fmt;

/// Where the equations are linearized: positions, the locked set, the
/// joint forces the rows carry and each cable's segment tensions.
#[derive(Clone, Debug)]
pub struct Linearization {
    /// Joint positions (m, 3 per joint).
    pub x: Vec<f64>,
    /// Per element: latched.
    pub locked: Vec<bool>,
    /// The joint forces f = A^T lambda the rows carry (N, 3 per joint):
    /// split by least work into the preload lambda*.
    pub row_forces_n: Vec<f64>,
    /// Per cable, the tension of each straight segment of its path (N).
    pub segment_tension_n: Vec<Vec<f64>>,
    /// Which geometry: "reference", "initial" or "state".
    pub geometry: &'static str,
}

impl Linearization {
    /// The deployed truss at rest: the reference geometry (the initial one
    /// where the model gives none), every sleeve latched, each cable at its
    /// motor tension along its whole path (at rest the pulleys' friction
    /// holds no tension difference: its blend is zero at zero sliding), the
    /// rows carrying what the cables, gravity and the compliant elements
    /// apply: f = -Q(X).
    pub fn deployed(model: &Model) -> Linearization {
        let (geometry, x) = match &model.reference {
            Some(r) => ("reference", r.clone()),
            None => ("initial", model.x0.clone()),
        };
        let mut locked = vec![false; model.elements.len()];
        for &e in &model.locks {
            locked[e] = true;
        }
        let segment_tension_n: Vec<Vec<f64>> = model
            .cables
            .iter()
            .map(|c| vec![c.tension_n; c.path.len().saturating_sub(1)])
            .collect();
        let n = model.n_coords();
        let mut q = vec![0.0; n];
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = model.mass[i] * model.gravity_m_s2[i % 3];
        }
        for (c, t) in model.cables.iter().zip(&segment_tension_n) {
            let eval = super::cable::CableEval {
                segment_tension_n: t.clone(),
                ..super::cable::CableEval::for_cable(c)
            };
            super::cable::add_forces(c, &eval, &x, &mut q);
        }
        super::springs::ElementSprings::new(model).add_forces(model, &x, &vec![0.0; n], &mut q);
        let row_forces_n = q.iter().map(|v| -v).collect();
        Linearization {
            x,
            locked,
            row_forces_n,
            segment_tension_n,
            geometry,
        }
    }

    /// A run's state as it is (mid-deployment, or deployed): its positions,
    /// locks, cable segment tensions, and the joint forces A^T lambda of its
    /// multipliers (inertia included: about a moving state these are the
    /// modes of the instant). A compliant latch still in its transient is
    /// counted open.
    pub fn of_state(model: &Model, state: &State) -> Linearization {
        let mut jac = Jacobian::pattern(model, &state.locked);
        jac.fill(model, &state.x);
        let mut f = vec![0.0; model.n_coords()];
        if state.lambda.len() == jac.nrows {
            jac.mul_t(&state.lambda, &mut f);
        }
        Linearization {
            x: state.x.clone(),
            locked: state.locked.clone(),
            row_forces_n: f,
            segment_tension_n: state
                .cables
                .iter()
                .map(|c| c.segment_tension_n.clone())
                .collect(),
            geometry: "state",
        }
    }
}

/// What a mode is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeKind {
    /// Strains members or works against a preload: omega^2 > 0.
    Elastic,
    /// Zero frequency: a mechanism the locked truss keeps.
    Mechanism,
    /// omega^2 < 0: the preload (compression) makes the state unstable.
    Unstable,
}

/// One natural mode.
#[derive(Clone, Debug, Serialize)]
pub struct Mode {
    /// omega^2 (rad^2/s^2): the eigenvalue.
    pub omega2_rad2_s2: f64,
    /// sqrt(|omega^2|) / 2 pi (Hz).
    pub frequency_hz: f64,
    pub kind: ModeKind,
    /// Effective mass fractions of translations along x, y, z and rotations
    /// about the x, y, z axes through the centre of mass: (phi^T M r)^2 /
    /// (phi^T M phi r^T M r) for each rigid-body field r (sum over all modes
    /// of a free body is 1 per field).
    pub participation: [f64; 6],
    /// What the largest participation names ("translation z", "rotation
    /// about z"), or "internal" where none is above 0.1.
    pub motion: String,
    /// Joint displacements, scaled so that the largest joint's is 1 (and its
    /// largest coordinate positive), [x, y, z] per joint.
    pub shape: Vec<[f64; 3]>,
}

/// The modes and the linearization they were found at.
#[derive(Clone, Debug, Serialize)]
pub struct Modes {
    pub geometry: &'static str,
    /// Coordinates, rigid rows (of which independent), degrees of freedom
    /// on their tangent space.
    pub coordinates: usize,
    pub rigid_rows: usize,
    pub rigid_rank: usize,
    pub degrees_of_freedom: usize,
    /// Member rows (elastic) and the largest |lambda*| of the preload (N).
    pub member_rows: usize,
    pub max_preload_n: f64,
    /// |A^T lambda* - f| / |f| of the preload split.
    pub preload_residual_rel: f64,
    /// Mechanisms counted among all the degrees of freedom (not only the
    /// modes asked for).
    pub mechanisms: usize,
    pub unstable: usize,
    /// The first elastic mode's frequency (Hz) among all the degrees of
    /// freedom, whether or not it is among the modes asked for.
    pub first_elastic_hz: Option<f64>,
    /// The lowest modes asked for, in increasing omega^2.
    pub modes: Vec<Mode>,
}

/// Why no modes.
#[derive(Debug)]
pub enum ModesError {
    /// The positions make an element's rows undefined (non-finite).
    Degenerate {
        element: String,
    },
    /// The rows cannot carry the given forces: the state is not an
    /// equilibrium of the locked truss (a mechanism the forces drive).
    NotInEquilibrium {
        residual_rel: f64,
    },
    /// The least-work split or a decomposition failed.
    Solver(SolverError),
    Decomposition(&'static str),
}

impl fmt::Display for ModesError {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            ModesError::Degenerate { element } => write!(
                f,
                "element `{element}` is degenerate at these positions (its rows are not finite)"
            ),
            ModesError::NotInEquilibrium { residual_rel } => write!(
                f,
                "the rows cannot carry the applied forces at this state (the least-work split leaves {residual_rel:.2e} of them): it is not an equilibrium of the locked truss, whose mechanisms the forces drive; linearize about a state where every sleeve has latched"
            ),
            ModesError::Solver(e) => write!(f, "the preload's least-work split failed: {e}"),
            ModesError::Decomposition(what) => write!(f, "the {what} did not converge"),
        }
    }
}

impl std::error::Error for ModesError {}

/// The local Hessian sum_r w_r H_r of an element's rows (3k x 3k over its
/// k joints, row-major), from its velocity-product term by polarization.
/// `v` is a zeroed scratch vector of all coordinates (left zeroed);
/// `rows` the element's row count and `out_rows` a scratch of that length.
fn element_hessian(
    el: &dyn Constraint,
    x: &[f64],
    weights: &[f64],
    v: &mut [f64],
    out_rows: &mut [f64],
    h: &mut [f64],
) {
    let joints = el.joints();
    let w = 3 * joints.len();
    let col = |c: usize| 3 * joints[c / 3] + c % 3;
    let mut q = |v: &mut [f64], a: usize, b: Option<usize>| -> f64 {
        v[col(a)] += 1.0;
        if let Some(b) = b {
            v[col(b)] += 1.0;
        }
        el.adot_xdot(x, v, out_rows);
        v[col(a)] = 0.0;
        if let Some(b) = b {
            v[col(b)] = 0.0;
        }
        out_rows.iter().zip(weights).map(|(o, w)| o * w).sum()
    };
    let diag: Vec<f64> = (0..w).map(|a| q(v, a, None)).collect();
    for a in 0..w {
        h[a * w + a] = diag[a];
        for b in a + 1..w {
            let hab = 0.5 * (q(v, a, Some(b)) - diag[a] - diag[b]);
            h[a * w + b] = hab;
            h[b * w + a] = hab;
        }
    }
}

/// K[cols, cols] += scale a a^T (a row of an element's block over `cols`).
fn add_outer(k: &mut nalgebra::DMatrix<f64>, cols: &[usize], a: &[f64], scale: f64) {
    for (i, ai) in a.iter().enumerate() {
        for (j, aj) in a.iter().enumerate() {
            k[(cols[i], cols[j])] += scale * ai * aj;
        }
    }
}

/// K[cols, cols] += sum_r w_r H_r of an element's rows (`element_hessian`),
/// nothing where every weight is 0.
fn add_hessian(
    k: &mut nalgebra::DMatrix<f64>,
    cols: &[usize],
    el: &dyn Constraint,
    x: &[f64],
    weights: &[f64],
    v: &mut [f64],
) {
    if weights.iter().all(|w| *w == 0.0) {
        return;
    }
    let w = cols.len();
    let (mut rows, mut h) = (vec![0.0; weights.len()], vec![0.0; w * w]);
    element_hessian(el, x, weights, v, &mut rows, &mut h);
    for i in 0..w {
        for j in 0..w {
            k[(cols[i], cols[j])] += h[i * w + j];
        }
    }
}

/// The natural modes at `lin`: the lowest `count` (all when larger than
/// the degrees of freedom).
pub fn natural_modes(
    model: &Model,
    lin: &Linearization,
    count: usize,
) -> Result<Modes, ModesError> {
    let n = model.n_coords();
    let x = &lin.x;
    let mut jac = Jacobian::pattern(model, &lin.locked);
    jac.fill(model, x);
    if let Some((e, _)) = jac.non_finite_element() {
        return Err(ModesError::Degenerate {
            element: model.elements[e].name().to_string(),
        });
    }
    // The preload: least-work multipliers of the joint forces the rows carry.
    let mut lambda = vec![0.0; jac.nrows];
    let f = &lin.row_forces_n;
    let f_norm = f.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut preload_residual_rel = 0.0;
    if f_norm > 0.0 && jac.nrows > 0 {
        LeastWork::new(SolverKind::Sparse)
            .multipliers(model, &jac, f, &mut lambda)
            .map_err(ModesError::Solver)?;
        let mut atl = vec![0.0; n];
        jac.mul_t(&lambda, &mut atl);
        let r = atl
            .iter()
            .zip(f)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        preload_residual_rel = r / f_norm;
        if preload_residual_rel > model.solver.modes_equilibrium_rel {
            return Err(ModesError::NotInEquilibrium {
                residual_rel: preload_residual_rel,
            });
        }
    }
    // Row compliances: members finite (a compliant latch in series with its
    // tube), the rest rigid (NaN).
    let mut compliance = Vec::new();
    LeastWork::row_compliance(model, &jac, &mut compliance);
    for b in &jac.blocks {
        if model.elements[b.element].latch_spring().is_some() {
            compliance[b.row0] = model.latched_sleeve_compliance_m_per_n(b.element);
        }
    }
    // K: elastic members, the rows' geometric stiffness, springs, cables.
    let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut v = vec![0.0; n];
    for b in &jac.blocks {
        let el = model.elements[b.element].as_ref();
        let w = Jacobian::width(b);
        let vals = &jac.values[b.offset..b.offset + b.rows * w];
        let cols: Vec<usize> = (0..w).map(|c| b.cols[c / 3] + c % 3).collect();
        for r in 0..b.rows {
            let c = compliance[b.row0 + r];
            if c.is_finite() {
                add_outer(&mut k, &cols, &vals[r * w..(r + 1) * w], 1.0 / c);
            }
        }
        let weights: Vec<f64> = lambda[b.row0..b.row0 + b.rows].iter().map(|l| -l).collect();
        add_hessian(&mut k, &cols, el, x, &weights, &mut v);
    }
    for el in &model.elements {
        let Some(s) = el.spring() else { continue };
        if el.contact_distance_m(x).is_some_and(|d| d <= 0.0) {
            continue; // (an end stop off its contact holds nothing)
        }
        let w = 3 * el.joints().len();
        let mut phi = vec![0.0; s.rows];
        let mut a = vec![0.0; s.rows * w];
        el.residual(x, &mut phi);
        el.jacobian(x, &mut a);
        let cols: Vec<usize> = (0..w).map(|c| 3 * el.joints()[c / 3] + c % 3).collect();
        let kk = s.stiffness_n_per_m;
        for r in 0..s.rows {
            add_outer(&mut k, &cols, &a[r * w..(r + 1) * w], kk);
        }
        // (the force -A^T k Phi: its geometric stiffness is + sum k Phi H)
        let weights: Vec<f64> = phi.iter().map(|p| kk * p).collect();
        add_hessian(&mut k, &cols, el.as_ref(), x, &weights, &mut v);
    }
    for (c, t) in model.cables.iter().zip(&lin.segment_tension_n) {
        for (s, &tj) in c.path.windows(2).zip(t) {
            let d = super::elements::at(x, s[1]) - super::elements::at(x, s[0]);
            let l = d.norm();
            let e = d / l;
            // T (I - e e^T) / l on (p, p) and (r, r), its negative on (p, r)
            for i in 0..3 {
                for j in 0..3 {
                    let g = tj * ((i == j) as u8 as f64 - e[i] * e[j]) / l;
                    k[(3 * s[0] + i, 3 * s[0] + j)] += g;
                    k[(3 * s[1] + i, 3 * s[1] + j)] += g;
                    k[(3 * s[0] + i, 3 * s[1] + j)] -= g;
                    k[(3 * s[1] + i, 3 * s[0] + j)] -= g;
                }
            }
        }
    }
    // The rigid rows, mass-scaled: B = A_r M^-1/2, and a basis of null(B).
    let inv_sqrt_m: Vec<f64> = model.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
    let rigid: Vec<usize> = (0..jac.nrows)
        .filter(|&r| !compliance[r].is_finite())
        .collect();
    let mut row_of = vec![usize::MAX; jac.nrows];
    for (i, &r) in rigid.iter().enumerate() {
        row_of[r] = i;
    }
    let mut bmat = faer::Mat::<f64>::zeros(rigid.len(), n);
    jac.for_each(|r, c, a| {
        if row_of[r] != usize::MAX {
            bmat[(row_of[r], c)] += a * inv_sqrt_m[c];
        }
    });
    let (basis, rigid_rank) = if rigid.is_empty() {
        (faer::Mat::<f64>::identity(n, n), 0)
    } else {
        let svd = bmat
            .svd()
            .map_err(|_| ModesError::Decomposition("SVD of the rigid rows"))?;
        let s = svd.S().column_vector();
        let sigma: Vec<f64> = (0..s.nrows()).map(|i| s[i]).collect();
        let r = super::rank::numerical_rank(&sigma);
        let vmat = svd.V();
        (
            faer::Mat::<f64>::from_fn(n, n - r, |i, j| vmat[(i, r + j)]),
            r,
        )
    };
    let dof = n - rigid_rank;
    // K~ = N^T M^-1/2 K M^-1/2 N
    let ks = faer::Mat::<f64>::from_fn(n, n, |i, j| k[(i, j)] * inv_sqrt_m[i] * inv_sqrt_m[j]);
    let kn = &ks * &basis;
    let mut kt = basis.transpose() * &kn;
    for i in 0..dof {
        for j in 0..i {
            let m = 0.5 * (kt[(i, j)] + kt[(j, i)]);
            kt[(i, j)] = m;
            kt[(j, i)] = m;
        }
    }
    let (omega2, z) = if dof == 0 {
        (Vec::new(), faer::Mat::<f64>::zeros(0, 0))
    } else {
        let evd = kt
            .self_adjoint_eigen(faer::Side::Lower)
            .map_err(|_| ModesError::Decomposition("eigendecomposition of the stiffness"))?;
        let s = evd.S().column_vector();
        ((0..dof).map(|i| s[i]).collect(), evd.U().to_owned())
    };
    let scale = omega2.iter().fold(0.0f64, |a, w| a.max(w.abs()));
    let tol = model.solver.modes_mechanism_rel * scale;
    let kind_of = |w2: f64| {
        if w2.abs() <= tol {
            ModeKind::Mechanism
        } else if w2 < 0.0 {
            ModeKind::Unstable
        } else {
            ModeKind::Elastic
        }
    };
    let mechanisms = omega2
        .iter()
        .filter(|w| kind_of(**w) == ModeKind::Mechanism)
        .count();
    let unstable = omega2
        .iter()
        .filter(|w| kind_of(**w) == ModeKind::Unstable)
        .count();
    let first_elastic_hz = omega2
        .iter()
        .find(|w| kind_of(**w) == ModeKind::Elastic)
        .map(|w| frequency_hz(*w));
    let fields = rigid_body_fields(model, x);
    let mut modes = Vec::new();
    for m in 0..count.min(dof) {
        let zm = z.col(m);
        let mut u = vec![0.0; n];
        for (i, ui) in u.iter_mut().enumerate() {
            *ui = inv_sqrt_m[i] * (0..dof).map(|j| basis[(i, j)] * zm[j]).sum::<f64>();
        }
        modes.push(describe(model, omega2[m], kind_of(omega2[m]), u, &fields));
    }
    let member_rows = compliance.iter().filter(|c| c.is_finite()).count();
    Ok(Modes {
        geometry: lin.geometry,
        coordinates: n,
        rigid_rows: rigid.len(),
        rigid_rank,
        degrees_of_freedom: dof,
        member_rows,
        max_preload_n: lambda.iter().fold(0.0, |a, l| a.max(l.abs())),
        preload_residual_rel,
        mechanisms,
        unstable,
        first_elastic_hz,
        modes,
    })
}

/// The deployed, latched truss's first elastic natural frequency (Hz; the
/// mechanisms and unstable modes before it skipped), as `simulate`'s and a
/// sweep's summaries report it: None beyond `rank_check_max_coords`
/// coordinates (the dense decompositions grow as their cube), or where the
/// modes cannot be had (the deployed state is no equilibrium) or there is
/// no elastic mode.
pub fn deployed_first_frequency_hz(model: &Model) -> Option<f64> {
    if model.n_coords() > model.solver.rank_check_max_coords {
        return None;
    }
    natural_modes(model, &Linearization::deployed(model), 0)
        .ok()?
        .first_elastic_hz
}

/// f = sqrt(|omega^2|) / (2 pi).
fn frequency_hz(omega2: f64) -> f64 {
    omega2.abs().sqrt() / (2.0 * std::f64::consts::PI)
}

/// The six rigid-body velocity fields (translations x, y, z; rotations about
/// x, y, z through the centre of mass) at `x`.
fn rigid_body_fields(model: &Model, x: &[f64]) -> [Vec<f64>; 6] {
    let nj = model.n_joints();
    let total: f64 = model.joints.iter().map(|j| j.mass_kg).sum();
    let mut c = [0.0; 3];
    for (j, joint) in model.joints.iter().enumerate() {
        for k in 0..3 {
            c[k] += joint.mass_kg * x[3 * j + k] / total;
        }
    }
    let mut f: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; 3 * nj]);
    for j in 0..nj {
        let r = [x[3 * j] - c[0], x[3 * j + 1] - c[1], x[3 * j + 2] - c[2]];
        for k in 0..3 {
            f[k][3 * j + k] = 1.0;
        }
        // omega_k x r
        let rot = [[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]];
        for (axis, w) in rot.iter().enumerate() {
            for k in 0..3 {
                f[3 + axis][3 * j + k] = w[k];
            }
        }
    }
    f
}

const MOTIONS: [&str; 6] = [
    "translation x",
    "translation y",
    "translation z",
    "rotation about x",
    "rotation about y",
    "rotation about z",
];

fn describe(
    model: &Model,
    omega2: f64,
    kind: ModeKind,
    u: Vec<f64>,
    fields: &[Vec<f64>; 6],
) -> Mode {
    let mdot = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .zip(&model.mass)
            .map(|((a, b), m)| a * b * m)
            .sum()
    };
    let uu = mdot(&u, &u);
    let mut participation = [0.0; 6];
    for (p, r) in participation.iter_mut().zip(fields) {
        let rr = mdot(r, r);
        if rr > 0.0 && uu > 0.0 {
            *p = mdot(&u, r).powi(2) / (uu * rr);
        }
    }
    let (best, pmax) =
        participation.iter().enumerate().fold(
            (0, 0.0),
            |acc, (i, p)| if *p > acc.1 { (i, *p) } else { acc },
        );
    let motion = if pmax > 0.1 {
        MOTIONS[best].to_string()
    } else {
        "internal".to_string()
    };
    let nj = model.n_joints();
    let mut big = (0.0, 0usize);
    for j in 0..nj {
        let d = (u[3 * j].powi(2) + u[3 * j + 1].powi(2) + u[3 * j + 2].powi(2)).sqrt();
        if d > big.0 {
            big = (d, j);
        }
    }
    let lead = (0..3)
        .map(|k| u[3 * big.1 + k])
        .fold(0.0f64, |a, v| if v.abs() > a.abs() { v } else { a });
    let s = if big.0 > 0.0 {
        lead.signum() / big.0
    } else {
        0.0
    };
    let shape = (0..nj)
        .map(|j| [u[3 * j] * s, u[3 * j + 1] * s, u[3 * j + 2] * s])
        .collect();
    Mode {
        omega2_rad2_s2: omega2,
        frequency_hz: frequency_hz(omega2),
        kind,
        participation,
        motion,
        shape,
    }
}
