//! Coplanarity of four joints p, a, b, c: (r_pa x r_pb) . r_pc = 0, one row, scaled
//! to a length by the initial arm lengths. Keeps a planar truss element (a
//! quadrilateral of bars whose hinges have parallel axes) in its plane.

use super::kernels::{coplanar_scale, Coplanar as Row};
use super::{at, Constraint, ElementError, ElementSpec};

#[derive(Debug)]
pub struct Coplanar {
    name: String,
    joints: [usize; 4],
    scale: f64,
}

impl Coplanar {
    fn row(&self) -> Row {
        let [p, a, b, c] = self.joints;
        Row {
            p,
            a,
            b,
            c,
            scale: self.scale,
        }
    }
}
/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.expect_joints(4, "p, a, b, c")?;
    spec.only_params(PARAMS)?;
    let [p, a, b, c] = [
        spec.joints[0],
        spec.joints[1],
        spec.joints[2],
        spec.joints[3],
    ];
    let (la, lb) = (
        (at(x0, a) - at(x0, p)).norm(),
        (at(x0, b) - at(x0, p)).norm(),
    );
    if la <= 1e-9 || lb <= 1e-9 || (at(x0, c) - at(x0, p)).norm() <= 1e-9 {
        return Err(ElementError::Geometry(
            "two of its joints coincide; check the joint positions".into(),
        ));
    }
    Ok(Box::new(Coplanar {
        name: spec.name.clone(),
        joints: [p, a, b, c],
        scale: coplanar_scale(la, lb),
    }))
}

impl Constraint for Coplanar {
    super::identity!("coplanar");
    fn rows(&self, _locked: bool) -> usize {
        1
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        out[0] = self.row().residual(x);
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        out[..12].fill(0.0);
        self.row().jacobian(x, out, [0, 3, 6, 9]);
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        out[0] = self.row().adot_xdot(x, v);
    }
}
