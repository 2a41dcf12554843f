//! Centroid support: fixes some coordinates of the mean position of a group of
//! joints, Phi_c = (1/N) sum_j X_{j,c} - Xbar0_c for each fixed axis c (linear,
//! Adot Xdot = 0; the row is scaled to a unit gradient). With `first_group = K`, the first K joints and the rest form two
//! groups whose centres keep their initial offset instead (concentric rings:
//! Phi_c = mean_A X_c - mean_B X_c - (its initial value)). It holds a structure at its centre, as a symmetric hub does,
//! without biasing a symmetric deployment: unlike a support at one joint it
//! needs no reaction while the centre of mass stays put.

use super::{Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Centroid {
    name: String,
    joints: Vec<usize>,
    /// (axis, fixed mean value in m)
    fixed: Vec<(usize, f64)>,
    /// Weight of each joint in the row: 1/N, or +1/K and -1/(N-K) for two groups.
    weights: Vec<f64>,
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &["fix", "first_group"];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    if spec.joints.is_empty() {
        return Err(ElementError::Geometry(
            "a centroid support needs at least one joint".into(),
        ));
    }
    spec.only_params(PARAMS)?;
    let fix = spec.text("fix")?.unwrap_or("xyz");
    if fix.is_empty() || fix.chars().any(|c| !"xyz".contains(c)) {
        return Err(ElementError::Geometry(format!(
            "`fix` = \"{fix}\"; give the fixed axes as letters from \"xyz\", e.g. \"z\""
        )));
    }
    let n = spec.joints.len();
    let weights: Vec<f64> = match spec.num("first_group")? {
        None => vec![1.0 / n as f64; n],
        Some(k) if k >= 1.0 && k < n as f64 && k.fract() == 0.0 => {
            let k = k as usize;
            (0..n).map(|i| if i < k { 1.0 / k as f64 } else { -1.0 / (n - k) as f64 }).collect()
        }
        Some(k) => {
            return Err(ElementError::Geometry(format!(
                "`first_group` = {k} must be a whole number from 1 to {} (the joints of the first group)",
                n - 1
            )))
        }
    };
    // Scale the row to a unit gradient (weights w / |w|): the row then reads in
    // metres times sqrt(N), and a group of hundreds of joints does not make S
    // ill-conditioned (its diagonal would otherwise be ~1/N of a bar's).
    let norm = weights.iter().map(|w| w * w).sum::<f64>().sqrt();
    let weights: Vec<f64> = weights.iter().map(|w| w / norm).collect();
    let fixed = (0..3)
        .filter(|axis| fix.contains(['x', 'y', 'z'][*axis]))
        .map(|axis| {
            (
                axis,
                spec.joints
                    .iter()
                    .zip(&weights)
                    .map(|(j, w)| w * x0[3 * j + axis])
                    .sum::<f64>(),
            )
        })
        .collect();
    Ok(Box::new(Centroid {
        name: spec.name.clone(),
        joints: spec.joints.clone(),
        fixed,
        weights,
    }))
}

impl Constraint for Centroid {
    super::identity!("centroid");
    fn rows(&self, _locked: bool) -> usize {
        self.fixed.len()
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        for (r, (axis, value)) in self.fixed.iter().enumerate() {
            out[r] = self
                .joints
                .iter()
                .zip(&self.weights)
                .map(|(j, w)| w * x[3 * j + axis])
                .sum::<f64>()
                - value;
        }
    }
    fn jacobian(&self, _x: &[f64], out: &mut [f64]) {
        let (n, w) = (self.joints.len(), 3 * self.joints.len());
        out[..w * self.fixed.len()].fill(0.0);
        for (r, (axis, _)) in self.fixed.iter().enumerate() {
            for jj in 0..n {
                out[r * w + 3 * jj + axis] = self.weights[jj];
            }
        }
    }
    fn adot_xdot(&self, _x: &[f64], _v: &[f64], out: &mut [f64]) {
        out[..self.fixed.len()].fill(0.0);
    }
}
