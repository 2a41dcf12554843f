//! Planar multiangular scissor element (the paper's Fig. 4): two angulated rods
//! i-o-j and k-o-l pinned at the common hub joint o. Each angulated rod is a rigid
//! triangle: the four arms io, jo, ko, lo and the two dummy bars ij and kl keep
//! their lengths (6 rows); all five points stay in one plane, written as two
//! coplanarity rows (r_oi x r_oj) . r_ok = 0 and (r_oi x r_oj) . r_ol = 0.
//!
//! 8 rows, full rank: 15 coordinates - 8 = 7 DOF (6 rigid + the scissor angle).
//! The plane is defined by rod i-o-j, so the element degenerates when that rod is
//! straight (r_oi x r_oj = 0): the build rejects such geometry.

use super::kernels::{coplanar_scale, Coplanar, Distance};
use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct AngulatedScissor {
    name: String,
    /// [i, o, j, k, l]
    joints: [usize; 5],
    lengths: [f64; 6],
    scale: f64,
    /// EA of the arms (N); the model's default when None.
    axial_stiffness_n: Option<f64>,
}

/// Index pairs (into `joints`) of the 6 distance rows: io, jo, ko, lo, ij, kl.
const PAIRS: [(usize, usize); 6] = [(1, 0), (1, 2), (1, 3), (1, 4), (0, 2), (3, 4)];

impl AngulatedScissor {
    fn bar(&self, r: usize) -> Distance {
        let (a, b) = PAIRS[r];
        Distance {
            a: self.joints[a],
            b: self.joints[b],
            length_m: self.lengths[r],
        }
    }
    fn planes(&self) -> [Coplanar; 2] {
        let [i, o, j, k, l] = self.joints;
        [
            Coplanar {
                p: o,
                a: i,
                b: j,
                c: k,
                scale: self.scale,
            },
            Coplanar {
                p: o,
                a: i,
                b: j,
                c: l,
                scale: self.scale,
            },
        ]
    }
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[super::AXIAL_STIFFNESS_KEY];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(5, "i, hub o, j of rod 1, then k, l of rod 2")?;
    spec.only_params(PARAMS)?;
    let j5 = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
        spec.joints[4],
    ];
    let mut lengths = [0.0; 6];
    for (r, (a, b)) in PAIRS.iter().enumerate() {
        lengths[r] = (at(x0, j5[*b]) - at(x0, j5[*a])).norm();
        if lengths[r] <= 1e-9 {
            return Err(ElementError::Geometry(
                "two of its joints coincide (zero-length arm); check the joint positions".into(),
            ));
        }
    }
    let (oi, oj) = (at(x0, j5[0]) - at(x0, j5[1]), at(x0, j5[2]) - at(x0, j5[1]));
    if oi.cross(&oj).norm() <= 1e-6 * oi.norm() * oj.norm() {
        return Err(ElementError::Geometry("rod i-o-j is straight, so it defines no plane; use a `scissor` element for straight rods".into()));
    }
    let scale = coplanar_scale(lengths[0], lengths[1]);
    Ok(Box::new(AngulatedScissor {
        name: spec.name.clone(),
        joints: j5,
        lengths,
        scale,
        axial_stiffness_n: spec.axial_stiffness()?,
    }))
}

impl Constraint for AngulatedScissor {
    super::identity!("angulated_scissor");
    /// The four arms from the hinge o to i, j, k, l.
    fn members(&self) -> &'static [[usize; 2]] {
        &[[0, 1], [1, 2], [3, 1], [1, 4]]
    }
    fn rows(&self, _locked: bool) -> usize {
        8
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        for r in 0..6 {
            out[r] = self.bar(r).residual(x);
        }
        let [p1, p2] = self.planes();
        out[6] = p1.residual(x);
        out[7] = p2.residual(x);
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let w = 15;
        out[..8 * w].fill(0.0);
        for (r, (a, b)) in PAIRS.iter().enumerate() {
            self.bar(r)
                .jacobian(x, &mut out[r * w..(r + 1) * w], 3 * a, 3 * b);
        }
        let [p1, p2] = self.planes();
        p1.jacobian(x, &mut out[6 * w..7 * w], [3, 0, 6, 9]);
        p2.jacobian(x, &mut out[7 * w..8 * w], [3, 0, 6, 12]);
    }
    /// A distance row touches its pair of joints; the planes through o, i,
    /// j touch k (row 6) or l (row 7) besides.
    fn row_touches(&self, _locked: bool, row: usize, joint: usize) -> bool {
        match row {
            0..6 => PAIRS[row].0 == joint || PAIRS[row].1 == joint,
            6 => joint != 4,
            _ => joint != 3,
        }
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        for r in 0..6 {
            out[r] = self.bar(r).adot_xdot(x, v);
        }
        let [p1, p2] = self.planes();
        out[6] = p1.adot_xdot(x, v);
        out[7] = p2.adot_xdot(x, v);
    }
    /// The four arms and the two dummy bars that keep each angulated rod rigid
    /// are members; the two coplanarity rows are not.
    fn row_compliance_m_per_n(&self, _locked: bool, ea_default_n: f64, out: &mut [f64]) {
        for (c, l) in out.iter_mut().zip(&self.lengths) {
            *c = super::member_compliance(*l, self.axial_stiffness_n, ea_default_n);
        }
        out[6..8].fill(f64::NAN);
    }
}
