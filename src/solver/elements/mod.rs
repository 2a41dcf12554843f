//! Constraint macroelements.
//!
//! Every element is a set of scleronomic constraint equations Phi_e(X) = 0 on the
//! Cartesian coordinates of a few joints. An element supplies three things:
//! the residual Phi_e, its Jacobian rows A_e = dPhi_e/dX restricted to its own
//! joints, and the convective term (dA_e/dt) Xdot = Xdot^T (d2 Phi_e / dX2) Xdot
//! that enters the acceleration equation A Xddot + Adot Xdot = 0.
//!
//! An element also describes itself: its lock condition if it latches
//! (`lock_gap`, `lock_condition`), and the members it contributes for drawing
//! (`members`). Adding an element type touches its own file and the
//! `REGISTRY` below.

use super::vec3::Vec3;
use std::collections::BTreeMap;
use std::fmt;

pub mod angulated_scissor;
pub mod bar;
pub mod centroid;
pub mod coplanar;
pub mod end_stop;
pub mod frame_hinge;
pub mod hinge_axis;
pub mod perpendicular;
pub mod plate;
pub mod rigid_body;
pub mod scissor;
pub mod sleeve;
pub mod support;
pub mod sync_hinge;

/// A parameter of an element as written in a model file.
#[derive(Clone, Debug, PartialEq)]
pub enum Param {
    Num(f64),
    Text(String),
}

/// The solver-side description of one element: its type name, its own name, the
/// indices of the joints it connects (in the order its type defines) and its
/// named parameters. The model layer builds these from the file.
#[derive(Clone, Debug)]
pub struct ElementSpec {
    pub kind: String,
    pub name: String,
    pub joints: Vec<usize>,
    pub params: BTreeMap<String, Param>,
}

impl ElementSpec {
    pub fn num(&self, key: &str) -> Result<Option<f64>, ElementError> {
        match self.params.get(key) {
            None => Ok(None),
            Some(Param::Num(v)) if v.is_finite() => Ok(Some(*v)),
            Some(Param::Num(v)) => Err(ElementError::Param(format!(
                "parameter `{key}` is {v}; it must be a finite number"
            ))),
            Some(Param::Text(s)) => Err(ElementError::Param(format!(
                "parameter `{key}` is the text \"{s}\"; it must be a number"
            ))),
        }
    }
    pub fn text(&self, key: &str) -> Result<Option<&str>, ElementError> {
        match self.params.get(key) {
            None => Ok(None),
            Some(Param::Text(s)) => Ok(Some(s)),
            Some(Param::Num(v)) => Err(ElementError::Param(format!(
                "parameter `{key}` is the number {v}; it must be text"
            ))),
        }
    }
    /// Rejects parameters the element type does not know (typos would otherwise be silent).
    pub fn only_params(&self, known: &[&str]) -> Result<(), ElementError> {
        for k in self.params.keys() {
            if !known.contains(&k.as_str()) {
                return Err(ElementError::Param(format!(
                    "unknown parameter `{k}` for a {} element (known: {})",
                    self.kind,
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                )));
            }
        }
        Ok(())
    }
    /// The element's axial stiffness EA (N) of its members, if the model file
    /// names one (`axial_stiffness_n`); positive and finite.
    pub fn axial_stiffness(&self) -> Result<Option<f64>, ElementError> {
        match self.num(AXIAL_STIFFNESS_KEY)? {
            Some(ea) if ea <= 0.0 => Err(ElementError::Param(format!(
                "`{AXIAL_STIFFNESS_KEY}` = {ea} must be positive (EA of the member, N)"
            ))),
            other => Ok(other),
        }
    }
    /// A spring-damper given by a stiffness key (N/m, > 0) and an optional
    /// damping key (N s/m, >= 0, default 0); None when neither is given.
    /// `what` names it in the error (a damping without a stiffness).
    pub fn spring_damper(
        &self,
        k_key: &str,
        c_key: &str,
        what: &str,
    ) -> Result<Option<(f64, f64)>, ElementError> {
        match (self.num(k_key)?, self.num(c_key)?) {
            (None, None) => Ok(None),
            (None, Some(_)) => Err(ElementError::Param(format!(
                "`{c_key}` needs `{k_key}` ({what})"
            ))),
            (Some(k), c) => {
                let c = c.unwrap_or(0.0);
                if k <= 0.0 || c < 0.0 {
                    return Err(ElementError::Param(format!(
                        "`{k_key}` = {k} must be > 0 and `{c_key}` = {c} >= 0"
                    )));
                }
                Ok(Some((k, c)))
            }
        }
    }
    pub fn expect_joints(&self, n: usize, roles: &str) -> Result<(), ElementError> {
        if self.joints.len() != n {
            return Err(ElementError::Joints(format!(
                "a {} element takes {n} joints ({roles}), but {} are given",
                self.kind,
                self.joints.len()
            )));
        }
        Ok(())
    }
}

/// The parameter that gives an element's members their axial stiffness EA (N).
pub const AXIAL_STIFFNESS_KEY: &str = "axial_stiffness_n";

/// Compliance L / EA (m/N) of a member of length `length_m` whose element gives
/// `ea_n` (else the model's default `ea_default_n`).
#[inline]
pub fn member_compliance(length_m: f64, ea_n: Option<f64>, ea_default_n: f64) -> f64 {
    length_m / ea_n.unwrap_or(ea_default_n)
}

/// Read-only access to joint positions or velocities stored as X = [x0 y0 z0 x1 ...].
#[inline]
pub fn at(x: &[f64], joint: usize) -> Vec3 {
    Vec3::new(x[3 * joint], x[3 * joint + 1], x[3 * joint + 2])
}

/// The lock condition of a lockable element: the signed gap whose zero is the
/// latch (m) and its rate (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LockCondition {
    pub gap_m: f64,
    pub rate_m_s: f64,
}

/// A compliant element's spring-damper (`Constraint::spring`): the element
/// imposes no rows; its residual Phi (`rows` of them, each a length, m) is
/// held by the force -A^T (k Phi + c A Xdot) on its joints, with elastic
/// energy 1/2 k |Phi|^2 (a gear train's torsional compliance, a soft hinge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementSpring {
    pub rows: usize,
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
    /// A contact that only pushes: a row's force f = k Phi + c A Xdot acts
    /// only where it has the sign of Phi (the overrun); where the damper
    /// would pull the members back into the contact it is 0 (an end stop
    /// separating faster than k Phi / c). False: a spring both ways (gears).
    pub unilateral: bool,
}

/// A constraint macroelement. Rows are the element's own equations; `jacobian`
/// writes `rows x 3*joints().len()` values, row-major, columns ordered as
/// (x, y, z) of `joints()[0]`, then of `joints()[1]`, and so on.
pub trait Constraint: Send + Sync + fmt::Debug {
    /// Type name as used in model files (`bar`, `scissor`, ...).
    fn kind(&self) -> &'static str;
    fn name(&self) -> &str;
    fn joints(&self) -> &[usize];
    /// Number of equations the element imposes. `locked` is only meaningful for
    /// elements that lock (sleeves): they impose nothing until they latch.
    fn rows(&self, locked: bool) -> usize;
    /// Phi_e(X), in metres (each row scaled to a length).
    fn residual(&self, x: &[f64], out: &mut [f64]);
    /// A_e = dPhi_e/dX on the element's joints.
    fn jacobian(&self, x: &[f64], out: &mut [f64]);
    /// (dA_e/dt) Xdot, the velocity-product term of the acceleration constraint.
    fn adot_xdot(&self, x: &[f64], v: &[f64], out: &mut [f64]);
    /// Whether row `row` (of `rows(locked)`) depends on the element's joint
    /// `joints()[joint]`: where it does not, its Jacobian entries there are
    /// zero at every configuration, and the products with A and the
    /// pattern of S = A M^-1 A^T skip them (a scissor's rod rows touch two of
    /// its four joints). Every joint by default.
    fn row_touches(&self, _locked: bool, _row: usize, _joint: usize) -> bool {
        true
    }
    /// For lockable elements: the signed gap g(X) whose zero is the latch
    /// condition (sleeve length minus design length, m). `None` if it never locks.
    fn lock_gap(&self, _x: &[f64]) -> Option<f64> {
        None
    }
    /// For lockable elements: the lock condition at (X, Xdot), the gap g and
    /// its rate dg/dt. The latch search asks for it (a sign change of g over
    /// a step, or g closing at the start and opening at the end: a touch).
    fn lock_condition(&self, _x: &[f64], _v: &[f64]) -> Option<LockCondition> {
        None
    }
    /// The members (rods, struts, edges) the element contributes, as pairs of
    /// positions in `joints()`: what the plots and the node draw. Elements
    /// that only constrain members (coplanarity, right angles, gears,
    /// supports, centroids, hinge axes) contribute none.
    fn members(&self) -> &'static [[usize; 2]] {
        &[]
    }
    /// Axial compliance c = L / (EA) (m/N) of each of the element's rows that
    /// is the length of a member, NaN for rows that are not (pivots,
    /// coplanarity, supports, hinges). `ea_default_n` stands for EA where the
    /// element names none. Redundant forces and impulses are shared by least
    /// work, min sum c_i lambda_i^2 (`crate::solver::least_work`).
    fn row_compliance_m_per_n(&self, _locked: bool, _ea_default_n: f64, out: &mut [f64]) {
        out.fill(f64::NAN);
    }
    /// For lockable elements with a compliant latch: its stiffness k (N/m)
    /// and damping c (N s/m). Engaged, the latch is a spring-damper about the
    /// lock length, tension T = k (l - L_lock) + c ldot, until its transient
    /// settles and it turns rigid. None: a rigid latch (an inelastic impact).
    fn latch_spring(&self) -> Option<(f64, f64)> {
        None
    }
    /// A compliant element: its spring-damper (then `rows` is 0, and
    /// `residual`, `jacobian` write the spring's rows). None: rigid rows.
    fn spring(&self) -> Option<ElementSpring> {
        None
    }
    /// For a unilateral spring (an end stop): the signed distance (m) past
    /// its contact, > 0 in contact (the overrun), <= 0 free (how far from
    /// it). The step cuts its sub-steps at the sign changes
    /// (`contact_cut_rel`). None: no contact.
    fn contact_distance_m(&self, _x: &[f64]) -> Option<f64> {
        None
    }
    /// For lockable elements: the current length and its rate (m, m/s), used to
    /// publish sleeves as prismatic joints.
    fn extension(&self, _x: &[f64], _v: &[f64]) -> Option<(f64, f64)> {
        None
    }
}

/// The three accessors every element writes alike, for structs with `name` and
/// `joints` fields.
macro_rules! identity {
    ($kind:literal) => {
        fn kind(&self) -> &'static str {
            $kind
        }
        fn name(&self) -> &str {
            &self.name
        }
        fn joints(&self) -> &[usize] {
            &self.joints
        }
    };
}
use identity;

type Builder = fn(&ElementSpec, &[f64]) -> Result<Box<dyn Constraint>, ElementError>;

/// The registry: model-file type name, what it is, the parameters its
/// constructor accepts (each module's `PARAMS`, which its `build` checks;
/// docs/model-format.md lists them, tests/cli/docs.rs holds the two equal),
/// and its constructor. The constructor receives the spec and the initial
/// positions X0 (for element dimensions taken from the initial geometry,
/// e.g. bar lengths).
pub const REGISTRY: &[(&str, &str, &[&str], Builder)] = &[
    ("bar", "constant-length member between 2 joints", bar::PARAMS,
        bar::build),
    (
        "sleeve",
        "telescopic member between 2 joints, free until it latches at `lock_length_m`",
        sleeve::PARAMS,
        sleeve::build,
    ),
    (
        "end_stop",
        "stroke end of a telescopic member between 2 joints: free within [`min_length_m`, `max_length_m`], a stiff spring-damper past it",
        end_stop::PARAMS,
        end_stop::build,
    ),
    (
        "scissor",
        "linear scissor-link element: rods i-j and k-l pinned at a common pivot",
        scissor::PARAMS,
        scissor::build,
    ),
    (
        "angulated_scissor",
        "planar multiangular scissor element on joints i, o, j, k, l",
        angulated_scissor::PARAMS,
        angulated_scissor::build,
    ),
    (
        "plate",
        "rigid plate on 4 corner joints (5 bars + coplanarity, full rank when flat)",
        plate::PARAMS,
        plate::build,
    ),
    (
        "coplanar",
        "keeps 4 joints in one plane (1 row)",
        coplanar::PARAMS,
        coplanar::build,
    ),
    (
        "hinge_axis",
        "revolute hinge fixed in a post's body: member p-a turns only about it (joints p, q, r, a)",
        hinge_axis::PARAMS,
        hinge_axis::build,
    ),
    (
        "frame_hinge",
        "revolute hinge fixed in a post's body whose frame member p-r shears: member p-a turns only about it (joints p, q, r, a)",
        hinge_axis::PARAMS,
        frame_hinge::build,
    ),
    (
        "centroid",
        "fixes coordinates (`fix`) of the mean position of any number of joints",
        centroid::PARAMS,
        centroid::build,
    ),
    (
        "perpendicular",
        "right-angle fitting: members p-q and p-r stay square (joints p, q, r; 1 row)",
        perpendicular::PARAMS,
        perpendicular::build,
    ),
    (
        "sync_hinge",
        "synchronizing gears at hinge p: members p-a and p-b fold as mirror images (joints p, q, r, a, b)",
        sync_hinge::PARAMS,
        sync_hinge::build,
    ),
    (
        "rigid_body",
        "any number of joints (at least 4, the first four not in one plane) moving as one rigid body, e.g. a spacecraft bus with the truss's mount points (3k - 6 rigid distance rows)",
        rigid_body::PARAMS,
        rigid_body::build,
    ),
    (
        "support",
        "fixes the named coordinates (`fix` = some of \"xyz\") of 1 joint",
        support::PARAMS,
        support::build,
    ),
];

pub fn build(spec: &ElementSpec, x0: &[f64]) -> Result<Box<dyn Constraint>, ElementError> {
    match REGISTRY.iter().find(|(k, _, _, _)| *k == spec.kind) {
        Some((_, _, _, b)) => b(spec, x0),
        None => Err(ElementError::Kind(format!(
            "unknown element type `{}` (known: {})",
            spec.kind,
            REGISTRY.iter().map(|r| r.0).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// Shared row kernels, so that elements composed of bars and coplanarity
/// conditions write each equation once.
pub mod kernels {
    use super::{at, Vec3};

    /// Distance row Phi = |X_b - X_a| - L. Jacobian [-e, e] with e the unit vector
    /// a->b; Adot Xdot = (|w|^2 - (e.w)^2) / l with w = Xdot_b - Xdot_a (the
    /// centripetal part of the relative velocity).
    pub struct Distance {
        pub a: usize,
        pub b: usize,
        pub length_m: f64,
    }
    impl Distance {
        pub fn residual(&self, x: &[f64]) -> f64 {
            (at(x, self.b) - at(x, self.a)).norm() - self.length_m
        }
        /// Writes the 6 entries for (a, b) at `out[ca..ca+3]`, `out[cb..cb+3]`.
        pub fn jacobian(&self, x: &[f64], out: &mut [f64], ca: usize, cb: usize) {
            let d = at(x, self.b) - at(x, self.a);
            let e = d / d.norm();
            for k in 0..3 {
                out[ca + k] = -e[k];
                out[cb + k] = e[k];
            }
        }
        pub fn adot_xdot(&self, x: &[f64], v: &[f64]) -> f64 {
            let d = at(x, self.b) - at(x, self.a);
            let w = at(v, self.b) - at(v, self.a);
            let l = d.norm();
            let e = d / l;
            (w.norm_squared() - e.dot(&w).powi(2)) / l
        }
    }

    /// Coplanarity of four points p, a, b, c: Phi = s (r_pa x r_pb) . r_pc with
    /// r_pq = X_q - X_p and a constant scale s (1/m^2) that makes Phi a length.
    /// dPhi/dX_a = s r_pb x r_pc, dPhi/dX_b = s r_pc x r_pa, dPhi/dX_c = s r_pa x r_pb,
    /// dPhi/dX_p = minus their sum. (The paper's Eq. 28 prints the b block with the
    /// wrong sign.) Adot Xdot = 2 s [(ra' x rb').rc + (ra' x rb).rc' + (ra x rb').rc'].
    pub struct Coplanar {
        pub p: usize,
        pub a: usize,
        pub b: usize,
        pub c: usize,
        pub scale: f64,
    }
    impl Coplanar {
        fn arms(&self, x: &[f64]) -> (Vec3, Vec3, Vec3) {
            let p = at(x, self.p);
            (at(x, self.a) - p, at(x, self.b) - p, at(x, self.c) - p)
        }
        pub fn residual(&self, x: &[f64]) -> f64 {
            let (ra, rb, rc) = self.arms(x);
            self.scale * ra.cross(&rb).dot(&rc)
        }
        /// Writes the 4 blocks of 3 at the given column offsets.
        pub fn jacobian(&self, x: &[f64], out: &mut [f64], cols: [usize; 4]) {
            let (ra, rb, rc) = self.arms(x);
            let ga = rb.cross(&rc) * self.scale;
            let gb = rc.cross(&ra) * self.scale;
            let gc = ra.cross(&rb) * self.scale;
            let gp = -(ga + gb + gc);
            for (g, c) in [gp, ga, gb, gc].iter().zip(cols) {
                for k in 0..3 {
                    out[c + k] += g[k];
                }
            }
        }
        pub fn adot_xdot(&self, x: &[f64], v: &[f64]) -> f64 {
            let (ra, rb, rc) = self.arms(x);
            let (va, vb, vc) = self.arms(v);
            2.0 * self.scale
                * (va.cross(&vb).dot(&rc) + va.cross(&rb).dot(&vc) + ra.cross(&vb).dot(&vc))
        }
    }

    /// Scale making a triple product of arms of length l1, l2 (and a third) a length.
    pub fn coplanar_scale(l1: f64, l2: f64) -> f64 {
        1.0 / (l1 * l2).max(1e-12)
    }
}

/// Why an element cannot be built from its spec (`build`); the message
/// says which parameter, joint or dimension, and what to change (the
/// model's loader adds the element, the file and the line).
#[derive(Clone, Debug, PartialEq)]
pub enum ElementError {
    /// No element type of that name.
    Kind(String),
    /// A parameter unknown to the type, of the wrong type, or out of range.
    Param(String),
    /// The number of joints the type takes.
    Joints(String),
    /// The initial geometry cannot make it (coincident joints, a zero
    /// length, an axis along a member).
    Geometry(String),
}

impl fmt::Display for ElementError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ElementError::Kind(m)
            | ElementError::Param(m)
            | ElementError::Joints(m)
            | ElementError::Geometry(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for ElementError {}
