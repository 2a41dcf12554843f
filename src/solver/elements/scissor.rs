//! Linear scissor-link element (SLE, the paper's Fig. 3): rod i-j and rod k-l
//! pinned at a common pivot O that divides both rods in the same ratio,
//! |Oi| = a, |Oj| = ratio * a (the paper's k), so O = (1-t) X_i + t X_j with
//! t = 1/(1+ratio).
//!
//! Rows (6, rank 5):
//! - two rod lengths |X_j - X_i| = L_ij, |X_l - X_k| = L_kl (Eq. 23);
//! - the pivot, 3 rows: (1-t)(X_i - X_k) + t (X_j - X_l) = 0, Eq. 25 divided by (1+k)
//!   so that it reads in metres;
//! - coplanarity of i, j, k, l (Eq. 27). It is implied by the pivot rows (two lines
//!   through a common point are coplanar) and kept on purpose: the paper has it,
//!   and it exercises the solver's handling of redundant rows.
//!
//! Free element: 12 coordinates - rank 5 = 7 DOF (6 rigid + the scissor angle).

use super::kernels::{coplanar_scale, Coplanar, Distance};
use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Scissor {
    name: String,
    joints: [usize; 4],
    /// Pivot position along each rod from its first joint, t = 1/(1+ratio).
    t: f64,
    l_ij: f64,
    l_kl: f64,
    /// EA of both rods (N); the model's default when None.
    axial_stiffness_n: Option<f64>,
}

impl Scissor {
    fn rods(&self) -> [Distance; 2] {
        let [i, j, k, l] = self.joints;
        [
            Distance {
                a: i,
                b: j,
                length_m: self.l_ij,
            },
            Distance {
                a: k,
                b: l,
                length_m: self.l_kl,
            },
        ]
    }
    fn plane(&self) -> Coplanar {
        let [i, j, k, l] = self.joints;
        Coplanar {
            p: i,
            a: j,
            b: k,
            c: l,
            scale: coplanar_scale(self.l_ij, self.l_kl),
        }
    }
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["ratio", super::AXIAL_STIFFNESS_KEY];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(4, "rod 1 from i to j, rod 2 from k to l")?;
    spec.only_params(PARAMS)?;
    let ratio = spec.num("ratio")?.unwrap_or(1.0);
    if ratio <= 0.0 {
        return Err(ElementError::Param(format!(
            "`ratio` = {ratio} (|Oj|/|Oi|) must be positive"
        )));
    }
    let [i, j, k, l] = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
    ];
    let l_ij = (at(x0, j) - at(x0, i)).norm();
    let l_kl = (at(x0, l) - at(x0, k)).norm();
    if l_ij <= 1e-9 || l_kl <= 1e-9 {
        return Err(ElementError::Geometry(
            "zero-length scissor rod; check the joint positions".into(),
        ));
    }
    Ok(Box::new(Scissor {
        name: spec.name.clone(),
        joints: [i, j, k, l],
        t: 1.0 / (1.0 + ratio),
        l_ij,
        l_kl,
        axial_stiffness_n: spec.axial_stiffness()?,
    }))
}

impl Constraint for Scissor {
    super::identity!("scissor");
    /// The two rods i-j and k-l.
    fn members(&self) -> &'static [[usize; 2]] {
        &[[0, 1], [2, 3]]
    }
    fn rows(&self, _locked: bool) -> usize {
        6
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        let [i, j, k, l] = self.joints;
        let [r1, r2] = self.rods();
        out[0] = r1.residual(x);
        out[1] = r2.residual(x);
        let pivot = (at(x, i) - at(x, k)) * (1.0 - self.t) + (at(x, j) - at(x, l)) * self.t;
        out[2..5].copy_from_slice(pivot.as_slice());
        out[5] = self.plane().residual(x);
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let w = 12;
        out[..6 * w].fill(0.0);
        let [r1, r2] = self.rods();
        r1.jacobian(x, &mut out[0..w], 0, 3);
        r2.jacobian(x, &mut out[w..2 * w], 6, 9);
        for c in 0..3 {
            let row = &mut out[(2 + c) * w..(3 + c) * w];
            row[c] = 1.0 - self.t;
            row[3 + c] = self.t;
            row[6 + c] = -(1.0 - self.t);
            row[9 + c] = -self.t;
        }
        self.plane()
            .jacobian(x, &mut out[5 * w..6 * w], [0, 3, 6, 9]);
    }
    /// Rod i-j (row 0) touches i and j, rod k-l (row 1) k and l; the pivot
    /// and coplanarity rows all four.
    fn row_touches(&self, _locked: bool, row: usize, joint: usize) -> bool {
        match row {
            0 => joint < 2,
            1 => joint >= 2,
            _ => true,
        }
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        let [r1, r2] = self.rods();
        out[0] = r1.adot_xdot(x, v);
        out[1] = r2.adot_xdot(x, v);
        out[2..5].fill(0.0); // the pivot rows are linear in X
        out[5] = self.plane().adot_xdot(x, v);
    }
    /// The two rod lengths are members; the pivot and coplanarity rows are not.
    fn row_compliance_m_per_n(&self, _locked: bool, ea_default_n: f64, out: &mut [f64]) {
        out.fill(f64::NAN);
        out[0] = super::member_compliance(self.l_ij, self.axial_stiffness_n, ea_default_n);
        out[1] = super::member_compliance(self.l_kl, self.axial_stiffness_n, ea_default_n);
    }
}
