//! Synchronizing hinge: the gear pair at a hinge joint p that makes the two
//! members p-a and p-b meeting there fold as mirror images of each other about
//! the hinge's plane of symmetry. The plane is spanned by the post p-q (the hinge
//! axis direction) and the radial member p-r. For members of equal length, mirror
//! images about that plane means their far ends are level along both directions:
//!     (X_a - X_b) . (X_q - X_p) / L_pq = 0     (equal elevation along the post)
//!     (X_a - X_b) . (X_r - X_p) / L_pr = 0     (equal distance along the radial member)
//! `mirror = "both"` (default) keeps both rows, "axial" or "radial" one of them.
//! Each row is bilinear: Adot Xdot = 2 (V_a - V_b) . (V_q - V_p) / L (likewise for r).
//! With `stiffness_n_per_m` (and `damping_n_s_per_m`) the gears are compliant
//! (a gear train's torsional compliance seen at the members' far ends): the
//! rows are not imposed but held by the spring-damper -A^T (k Phi + c A Xdot).

use super::{at, Constraint, ElementError, ElementSpec, ElementSpring};

#[derive(Debug)]
pub struct SyncHinge {
    name: String,
    /// [p, q, r, a, b]
    joints: [usize; 5],
    /// Which of the axes q (index 1) and r (index 2) carry a row, with 1/L scales.
    axes: Vec<(usize, f64)>,
    /// Compliant gears: stiffness (N/m) and damping (N s/m) on the rows.
    spring: Option<(f64, f64)>,
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["mirror", "stiffness_n_per_m", "damping_n_s_per_m"];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(5, "hinge p, post end q, radial end r, member ends a and b")?;
    spec.only_params(PARAMS)?;
    let spring = spec.spring_damper("stiffness_n_per_m", "damping_n_s_per_m", "compliant gears")?;
    let j = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
        spec.joints[4],
    ];
    let which: &[usize] = match spec.text("mirror")?.unwrap_or("both") {
        "both" => &[1, 2],
        "axial" => &[1],
        "radial" => &[2],
        other => {
            return Err(ElementError::Geometry(format!(
                "`mirror` = \"{other}\"; use \"both\", \"axial\" or \"radial\""
            )))
        }
    };
    let mut axes = Vec::new();
    for &k in which {
        let l = (at(x0, j[k]) - at(x0, j[0])).norm();
        if l <= 1e-9 {
            return Err(ElementError::Geometry(
                "the hinge axis or radial member has zero length; check the joint positions".into(),
            ));
        }
        axes.push((k, 1.0 / l));
    }
    Ok(Box::new(SyncHinge {
        name: spec.name.clone(),
        joints: j,
        axes,
        spring,
    }))
}

impl Constraint for SyncHinge {
    super::identity!("sync_hinge");
    fn rows(&self, _locked: bool) -> usize {
        if self.spring.is_some() {
            0
        } else {
            self.axes.len()
        }
    }
    fn spring(&self) -> Option<ElementSpring> {
        self.spring.map(|(k, c)| ElementSpring {
            rows: self.axes.len(),
            stiffness_n_per_m: k,
            damping_n_s_per_m: c,
            unilateral: false,
        })
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        let [p, _, _, a, b] = self.joints;
        let d = at(x, a) - at(x, b);
        for (r, (k, s)) in self.axes.iter().enumerate() {
            out[r] = d.dot(&(at(x, self.joints[*k]) - at(x, p))) * s;
        }
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let w = 15;
        let [p, _, _, a, b] = self.joints;
        let d = at(x, a) - at(x, b);
        out[..w * self.axes.len()].fill(0.0);
        for (r, (k, s)) in self.axes.iter().enumerate() {
            let axis = (at(x, self.joints[*k]) - at(x, p)) * *s;
            let row = &mut out[r * w..(r + 1) * w];
            for c in 0..3 {
                row[c] -= d[c] * s; // p
                row[3 * k + c] += d[c] * s; // q or r
                row[9 + c] += axis[c]; // a
                row[12 + c] -= axis[c]; // b
            }
        }
    }
    fn adot_xdot(&self, _x: &[f64], v: &[f64], out: &mut [f64]) {
        let [p, _, _, a, b] = self.joints;
        let dv = at(v, a) - at(v, b);
        for (r, (k, s)) in self.axes.iter().enumerate() {
            out[r] = 2.0 * dv.dot(&(at(v, self.joints[*k]) - at(v, p))) * s;
        }
    }
}
