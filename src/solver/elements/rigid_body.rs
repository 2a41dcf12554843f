//! Rigid body: any number k >= 4 of joints that move as one body (a
//! spacecraft bus with the truss's mount points on it). The body is held by
//! 3k - 6 distance rows, none a member (rigid, as supports and pivots are):
//! the six edges of the tetrahedron of its first four joints (which must not
//! be coplanar), and from every further joint its distances to the three of
//! those four that make the largest tetrahedron with it (a point is fixed
//! in a body by three distances to points not in one plane with it).
//! Phi_r = |X_b - X_a| - L_r, L_r from the initial geometry.
//!
//! The body's mass and inertia are its joints' lumped masses: six joints at
//! +-a along the principal axes from its centre, each pair of mass mu_k
//! each, carry mass M and inertia J = diag(J_x, J_y, J_z) exactly when
//! a^2 = tr(J) / (2 M) and mu_k = M (tr(J)/2 - J_k) / tr(J) (the
//! generators' `--mount bus` builds it so).

use super::kernels::Distance;
use super::{at, Constraint, ElementError, ElementSpec};
use crate::solver::vec3::Vec3;

#[derive(Debug)]
pub struct RigidBody {
    name: String,
    joints: Vec<usize>,
    /// Per row: the positions in `joints` of its two ends and its length.
    links: Vec<(usize, usize, f64)>,
}

/// The parameters a model file may give this element (`elements::REGISTRY`).
pub const PARAMS: &[&str] = &[];

/// Six times the volume of the tetrahedron p, a, b, c: (a - p) . ((b - p) x (c - p)).
fn volume6(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f64 {
    (a - p).dot(&(b - p).cross(&(c - p)))
}

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    spec.only_params(PARAMS)?;
    let k = spec.joints.len();
    if k < 4 {
        return Err(ElementError::Joints(format!(
            "a rigid body needs at least 4 joints (its first four not in one plane), got {k}"
        )));
    }
    let p = |i: usize| at(x0, spec.joints[i]);
    let dist = |i: usize, j: usize| (at(x0, spec.joints[j]) - at(x0, spec.joints[i])).norm();
    let size = (0..k)
        .flat_map(|i| (0..k).map(move |j| (i, j)))
        .map(|(i, j)| dist(i, j))
        .fold(0.0, f64::max);
    let base = volume6(p(0), p(1), p(2), p(3)).abs();
    if !(base > 1e-6 * size.powi(3)) {
        return Err(ElementError::Geometry(format!(
            "the first four joints of a rigid body must not lie in one plane (their tetrahedron's volume is {:.3e} m^3); list four joints that span the body first",
            base / 6.0
        )));
    }
    let mut links = Vec::with_capacity(3 * k - 6);
    for i in 0..4 {
        for j in i + 1..4 {
            links.push((i, j, dist(i, j)));
        }
    }
    for i in 4..k {
        let triples = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        let (best, vol) = triples
            .iter()
            .map(|t| (t, volume6(p(i), p(t[0]), p(t[1]), p(t[2])).abs()))
            .fold(
                (&triples[0], -1.0),
                |acc, c| if c.1 > acc.1 { c } else { acc },
            );
        if !(vol > 1e-6 * size.powi(3)) {
            return Err(ElementError::Geometry(format!(
                "joint {} of the rigid body lies in a plane with every three of its first four joints; move it off them",
                i + 1
            )));
        }
        for &j in best {
            links.push((j, i, dist(j, i)));
        }
    }
    Ok(Box::new(RigidBody {
        name: spec.name.clone(),
        joints: spec.joints.clone(),
        links,
    }))
}

impl RigidBody {
    fn row(&self, r: usize) -> Distance {
        let (a, b, l) = self.links[r];
        Distance {
            a: self.joints[a],
            b: self.joints[b],
            length_m: l,
        }
    }
}

impl Constraint for RigidBody {
    super::identity!("rigid_body");
    fn rows(&self, _locked: bool) -> usize {
        self.links.len()
    }
    fn residual(&self, x: &[f64], out: &mut [f64]) {
        for (r, o) in out.iter_mut().enumerate() {
            *o = self.row(r).residual(x);
        }
    }
    fn jacobian(&self, x: &[f64], out: &mut [f64]) {
        let w = 3 * self.joints.len();
        out.fill(0.0);
        for r in 0..self.links.len() {
            let (a, b, _) = self.links[r];
            self.row(r)
                .jacobian(x, &mut out[r * w..(r + 1) * w], 3 * a, 3 * b);
        }
    }
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        for (r, o) in out.iter_mut().enumerate() {
            *o = self.row(r).adot_xdot(x, v);
        }
    }
}
