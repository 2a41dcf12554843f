//! Rigid plate on four corner joints i, j, k, l (in cyclic order; the paper's Fig. 5).
//!
//! The paper replaces the plate by six virtual bars ij, jk, kl, li, ik, jl. For a
//! flat plate (every real panel) that framework has a first-order infinitesimal
//! mechanism: corner l can move out of the plane with no first-order change of
//! any bar length, so the six rows have rank 5 and the null-space method sees a
//! spurious seventh DOF. The default formulation here keeps five bars (the
//! triangle ijk and the two bars kl, li that place l) and adds one coplanarity
//! row (r_ij x r_ik) . r_il = 0 instead of the second diagonal: full rank 6 when
//! flat, 12 - 6 = 6 DOF. `formulation = "six_bars"` gives the paper's form, for
//! comparison (and for non-flat quadrilaterals, where it is the right one).

use super::kernels::{coplanar_scale, Coplanar, Distance};
use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Plate {
    name: String,
    joints: [usize; 4],
    six_bars: bool,
    lengths: [f64; 6],
    scale: f64,
    /// EA of the plate's edge bars (N); the model's default when None.
    axial_stiffness_n: Option<f64>,
}

/// Corner-index pairs of the bars: ij, jk, kl, li, ik, and (six-bar form only) jl.
const PAIRS: [(usize, usize); 6] = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 2), (1, 3)];

impl Plate {
    fn bar(&self, r: usize) -> Distance {
        let (a, b) = PAIRS[r];
        Distance {
            a: self.joints[a],
            b: self.joints[b],
            length_m: self.lengths[r],
        }
    }
    fn plane(&self) -> Coplanar {
        let [i, j, k, l] = self.joints;
        Coplanar {
            p: i,
            a: j,
            b: k,
            c: l,
            scale: self.scale,
        }
    }
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["formulation", super::AXIAL_STIFFNESS_KEY];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(4, "its corners i, j, k, l in cyclic order")?;
    spec.only_params(PARAMS)?;
    let six_bars = match spec.text("formulation")?.unwrap_or("flat") {
        "flat" => false,
        "six_bars" => true,
        other => {
            return Err(ElementError::Geometry(format!(
                "`formulation` = \"{other}\"; use \"flat\" (5 bars + coplanarity) or \"six_bars\""
            )))
        }
    };
    let j4 = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
    ];
    let mut lengths = [0.0; 6];
    for (r, (a, b)) in PAIRS.iter().enumerate() {
        lengths[r] = (at(x0, j4[*b]) - at(x0, j4[*a])).norm();
        if lengths[r] <= 1e-9 {
            return Err(ElementError::Geometry(
                "two of its corners coincide; check the joint positions".into(),
            ));
        }
    }
    let scale = coplanar_scale(lengths[0], lengths[4]);
    Ok(Box::new(Plate {
        name: spec.name.clone(),
        joints: j4,
        six_bars,
        lengths,
        scale,
        axial_stiffness_n: spec.axial_stiffness()?,
    }))
}

impl Constraint for Plate {
    super::identity!("plate");
    /// The four edges (either formulation).
    fn members(&self) -> &'static [[usize; 2]] {
        &[[0, 1], [1, 2], [2, 3], [3, 0]]
    }
    fn rows(&self, _locked: bool) -> usize {
        6
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        for r in 0..5 {
            out[r] = self.bar(r).residual(x);
        }
        out[5] = if self.six_bars {
            self.bar(5).residual(x)
        } else {
            self.plane().residual(x)
        };
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let w = 12;
        out[..6 * w].fill(0.0);
        let bars = if self.six_bars { 6 } else { 5 };
        for (r, (a, b)) in PAIRS.iter().enumerate().take(bars) {
            self.bar(r)
                .jacobian(x, &mut out[r * w..(r + 1) * w], 3 * a, 3 * b);
        }
        if !self.six_bars {
            self.plane()
                .jacobian(x, &mut out[5 * w..6 * w], [0, 3, 6, 9]);
        }
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        for r in 0..5 {
            out[r] = self.bar(r).adot_xdot(x, v);
        }
        out[5] = if self.six_bars {
            self.bar(5).adot_xdot(x, v)
        } else {
            self.plane().adot_xdot(x, v)
        };
    }
    /// The bars are members (five, or six in the paper's form); the
    /// coplanarity row is not.
    fn row_compliance_m_per_n(&self, _locked: bool, ea_default_n: f64, out: &mut [f64]) {
        for (c, l) in out.iter_mut().zip(&self.lengths) {
            *c = super::member_compliance(*l, self.axial_stiffness_n, ea_default_n);
        }
        if !self.six_bars {
            out[5] = f64::NAN;
        }
    }
}
