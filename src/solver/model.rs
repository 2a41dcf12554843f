//! The immutable description of a truss: joints with lumped masses, constraint
//! elements, drive cables, the optional reference deployed geometry and the
//! environment. What a step changes lives in [`crate::solver::State`].

use super::elements::{self, Constraint, ElementSpec};
use super::jacobian::Jacobian;
use super::settings::SolverSettings;

/// Default axial stiffness EA of every member (N) where neither the element nor
/// `[settings] axial_stiffness_n` gives one: a carbon-fibre tube of 20 mm
/// outer diameter and 1 mm wall (A = 59.7 mm^2) with an axial modulus of
/// 100 GPa, typical of deployable-truss struts. Only the ratios of member
/// compliances matter to the rigid model (they decide how redundant members
/// share forces and latch impulses), so one model-wide value gives the
/// length-weighted split.
pub const DEFAULT_AXIAL_STIFFNESS_N: f64 = 6.0e6;

#[derive(Clone, Debug)]
pub struct Joint {
    pub name: String,
    /// Lumped mass of the joint and half of each strut meeting there (kg).
    pub mass_kg: f64,
}

/// An active drive cable. `path[0]` is the joint where the cable leaves the motor
/// drum; `path[last]` is where its far end is anchored; every joint in between
/// carries a pulley the cable wraps around.
#[derive(Clone, Debug)]
pub struct Cable {
    pub name: String,
    pub path: Vec<usize>,
    /// Motor-end tension at start, until a command changes it (N).
    pub tension_n: f64,
    /// Largest motor tension a command may ask for (N).
    pub max_tension_n: f64,
    /// Coulomb friction coefficient between cable and pulleys.
    pub friction_mu: f64,
    /// Line density of the cable (kg/m); enters the corrected Eq. 17 on the pulley arcs.
    pub line_density_kg_per_m: f64,
    pub pulley_radius_m: f64,
    /// Sliding speed below which the friction direction is blended linearly
    /// through zero (m/s): the capstan exponent is mu*theta*clamp(s/s_slip, -1, 1),
    /// so that the friction force does not chatter when sliding stops.
    pub slip_speed_m_s: f64,
}

impl Cable {
    /// The cable's length along its path at the positions x (m): the sum of
    /// its straight segments between pulleys.
    pub fn length_m(&self, x: &[f64]) -> f64 {
        self.path
            .windows(2)
            .map(|w| (elements::at(x, w[1]) - elements::at(x, w[0])).norm())
            .sum()
    }

    /// grad L . w: the length's rate under joint velocities w (m/s), or
    /// grad L . a for any joint vector a.
    pub fn length_rate(&self, x: &[f64], w: &[f64]) -> f64 {
        self.path
            .windows(2)
            .map(|s| {
                let d = elements::at(x, s[1]) - elements::at(x, s[0]);
                d.dot(&(elements::at(w, s[1]) - elements::at(w, s[0]))) / d.norm()
            })
            .sum()
    }

    /// Lddot = sum_j e_j . (a_q - a_p) + (|w_j|^2 - (e_j . w_j)^2) / l_j
    /// (m/s^2), w_j the segment's relative velocity.
    pub fn length_accel(&self, x: &[f64], v: &[f64], a: &[f64]) -> f64 {
        use elements::at;
        self.path
            .windows(2)
            .map(|s| {
                let d = at(x, s[1]) - at(x, s[0]);
                let l = d.norm();
                let e = d / l;
                let w = at(v, s[1]) - at(v, s[0]);
                e.dot(&(at(a, s[1]) - at(a, s[0]))) + (w.norm_squared() - e.dot(&w).powi(2)) / l
            })
            .sum()
    }

    /// q += scale grad L.
    pub fn add_length_gradient(&self, x: &[f64], scale: f64, q: &mut [f64]) {
        for s in self.path.windows(2) {
            let (p, r) = (s[0], s[1]);
            let d = elements::at(x, r) - elements::at(x, p);
            let e = d * (scale / d.norm());
            for k in 0..3 {
                q[3 * r + k] += e[k];
                q[3 * p + k] -= e[k];
            }
        }
    }
}

#[derive(Debug)]
pub struct Model {
    pub name: String,
    pub joints: Vec<Joint>,
    /// Initial positions X0 = [x0 y0 z0 x1 ...] (m).
    pub x0: Vec<f64>,
    /// Reference deployed positions from closed-form geometry, if known (m).
    pub reference: Option<Vec<f64>>,
    pub elements: Vec<Box<dyn Constraint>>,
    pub cables: Vec<Cable>,
    pub gravity_m_s2: [f64; 3],
    /// Viscous damping on each joint's absolute velocity (N s/m).
    pub damping_n_s_per_m: f64,
    /// Default time step and end time for offline runs (s).
    pub dt_s: f64,
    pub end_time_s: f64,
    /// Per coordinate: mass (kg) and its inverse, 3 entries per joint.
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// Indices into `elements` of the elements that latch (sleeves).
    pub locks: Vec<usize>,
    /// Indices into `elements` of the unilateral springs (end stops: a
    /// `Constraint::contact_distance_m`), whose contacts cut the sub-steps.
    pub contacts: Vec<usize>,
    /// Tolerances and iteration limits of the solver (the model file's
    /// `[solver]` table; defaults when it has none).
    pub solver: SolverSettings,
    /// EA of members whose element gives none (N).
    pub axial_stiffness_n: f64,
    /// Compliance L/EA of the stiffest member (m/N): the scale against which
    /// rows that are not members are made rigid in least-work sharing.
    pub stiffest_compliance_m_per_n: f64,
}

pub struct ModelParts {
    pub name: String,
    pub joints: Vec<Joint>,
    pub x0: Vec<f64>,
    pub reference: Option<Vec<f64>>,
    pub elements: Vec<ElementSpec>,
    pub cables: Vec<Cable>,
    pub gravity_m_s2: [f64; 3],
    pub damping_n_s_per_m: f64,
    pub dt_s: f64,
    pub end_time_s: f64,
    /// Model-wide default EA of members (N); `DEFAULT_AXIAL_STIFFNESS_N` when None.
    pub axial_stiffness_n: Option<f64>,
}

impl Model {
    /// The lock gap of element e at x (m; NaN for an element that does not lock).
    pub fn lock_gap_m(&self, e: usize, x: &[f64]) -> f64 {
        self.elements[e].lock_gap(x).unwrap_or(f64::NAN)
    }

    /// Builds the model, checking what the solver relies on. Errors name the
    /// offending item (`what`); the model-file layer adds file and line.
    pub fn build(p: ModelParts) -> Result<Model, ModelError> {
        let n = p.joints.len();
        let err = |at: ModelPart, what: String| ModelError { at, what };
        if p.x0.len() != 3 * n || p.x0.iter().any(|v| !v.is_finite()) {
            return Err(err(
                ModelPart::Joints,
                "joint positions must be 3 finite numbers per joint".into(),
            ));
        }
        let mut mass = Vec::with_capacity(3 * n);
        for j in &p.joints {
            if !(j.mass_kg.is_finite() && j.mass_kg > 0.0) {
                return Err(err(
                    ModelPart::Joints,
                    format!(
                        "joint `{}` has mass {} kg; every joint needs a positive lumped mass",
                        j.name, j.mass_kg
                    ),
                ));
            }
            mass.extend([j.mass_kg; 3]);
        }
        let inv_mass = mass.iter().map(|m| 1.0 / m).collect();
        let mut elems = Vec::with_capacity(p.elements.len());
        for (i, spec) in p.elements.iter().enumerate() {
            if let Some(&bad) = spec.joints.iter().find(|&&j| j >= n) {
                return Err(err(
                    ModelPart::Element(i),
                    format!(
                        "element `{}` refers to joint index {bad}, but there are {n} joints",
                        spec.name
                    ),
                ));
            }
            for (a, ja) in spec.joints.iter().enumerate() {
                if spec.joints[..a].contains(ja) {
                    return Err(err(
                        ModelPart::Element(i),
                        format!(
                            "element `{}` names joint `{}` twice",
                            spec.name, p.joints[*ja].name
                        ),
                    ));
                }
            }
            elems.push(elements::build(spec, &p.x0).map_err(|e| {
                err(
                    ModelPart::Element(i),
                    format!("element `{}` ({}): {e}", spec.name, spec.kind),
                )
            })?);
        }
        for (i, c) in p.cables.iter().enumerate() {
            if c.path.len() < 2 {
                return Err(err(ModelPart::Cable(i), format!("cable `{}` has a path of {} joint(s); it needs at least 2 (motor end, anchored end)", c.name, c.path.len())));
            }
            for w in c.path.windows(2) {
                if w[0] == w[1] || w.iter().any(|&j| j >= n) {
                    return Err(err(
                        ModelPart::Cable(i),
                        format!(
                            "cable `{}`: consecutive path joints must be distinct existing joints",
                            c.name
                        ),
                    ));
                }
                let l = (elements::at(&p.x0, w[1]) - elements::at(&p.x0, w[0])).norm();
                if l < 1e-9 {
                    return Err(err(
                        ModelPart::Cable(i),
                        format!(
                            "cable `{}`: the segment {} -> {} has zero length",
                            c.name, p.joints[w[0]].name, p.joints[w[1]].name
                        ),
                    ));
                }
            }
            let nums = [
                c.tension_n,
                c.max_tension_n,
                c.friction_mu,
                c.line_density_kg_per_m,
                c.pulley_radius_m,
                c.slip_speed_m_s,
            ];
            if nums.iter().any(|v| !v.is_finite() || *v < 0.0) || c.slip_speed_m_s <= 0.0 {
                return Err(err(ModelPart::Cable(i), format!("cable `{}`: tensions, friction, density and radius must be finite and >= 0, and the slip speed > 0", c.name)));
            }
            if c.tension_n > c.max_tension_n {
                return Err(err(
                    ModelPart::Cable(i),
                    format!(
                        "cable `{}`: tension {} N exceeds its max_tension_n {} N",
                        c.name, c.tension_n, c.max_tension_n
                    ),
                ));
            }
        }
        if let Some(r) = &p.reference {
            if r.len() != 3 * n || r.iter().any(|v| !v.is_finite()) {
                return Err(err(
                    ModelPart::Joints,
                    "reference positions must be 3 finite numbers for every joint".into(),
                ));
            }
        }
        if !(p.dt_s.is_finite() && p.dt_s > 0.0 && p.end_time_s.is_finite() && p.end_time_s > 0.0) {
            return Err(err(
                ModelPart::Settings,
                format!(
                    "dt_s = {} and end_time_s = {} must be positive",
                    p.dt_s, p.end_time_s
                ),
            ));
        }
        if !(p.damping_n_s_per_m.is_finite() && p.damping_n_s_per_m >= 0.0)
            || p.gravity_m_s2.iter().any(|g| !g.is_finite())
        {
            return Err(err(
                ModelPart::Settings,
                "damping must be finite and >= 0, gravity finite".into(),
            ));
        }
        let axial_stiffness_n = p.axial_stiffness_n.unwrap_or(DEFAULT_AXIAL_STIFFNESS_N);
        if !(axial_stiffness_n.is_finite() && axial_stiffness_n > 0.0) {
            return Err(err(
                ModelPart::Settings,
                format!("axial_stiffness_n = {axial_stiffness_n} N must be positive and finite"),
            ));
        }
        if let Some(i) = first_over_jacobian_limit(&elems, u32::MAX as usize) {
            return Err(err(
                ModelPart::Element(i),
                format!(
                    "the constraint Jacobian passes {} entries at element `{}`: the model is too large \
                     for the solver's 32-bit indices; split it or use fewer elements",
                    u32::MAX,
                    p.elements[i].name
                ),
            ));
        }
        let mut stiffest_compliance_m_per_n = f64::INFINITY;
        let mut buf = Vec::new();
        for e in &elems {
            buf.resize(e.rows(true), f64::NAN);
            e.row_compliance_m_per_n(true, axial_stiffness_n, &mut buf);
            for &c in buf.iter().filter(|c| c.is_finite()) {
                stiffest_compliance_m_per_n = stiffest_compliance_m_per_n.min(c);
            }
        }
        if !stiffest_compliance_m_per_n.is_finite() {
            stiffest_compliance_m_per_n = 1.0 / axial_stiffness_n; // no members at all
        }
        // (the elements that latch, and the end stops, by what they answer
        // at the initial positions)
        let indices = |has: &dyn Fn(&dyn Constraint) -> bool| -> Vec<usize> {
            (0..elems.len())
                .filter(|&i| has(elems[i].as_ref()))
                .collect()
        };
        let locks = indices(&|e| e.lock_gap(&p.x0).is_some());
        let contacts = indices(&|e| e.contact_distance_m(&p.x0).is_some());
        Ok(Model {
            name: p.name,
            joints: p.joints,
            x0: p.x0,
            reference: p.reference,
            elements: elems,
            cables: p.cables,
            gravity_m_s2: p.gravity_m_s2,
            damping_n_s_per_m: p.damping_n_s_per_m,
            dt_s: p.dt_s,
            end_time_s: p.end_time_s,
            mass,
            inv_mass,
            locks,
            contacts,
            solver: SolverSettings::default(),
            axial_stiffness_n,
            stiffest_compliance_m_per_n,
        })
    }

    /// A latched sleeve's row compliance (m/N): its tube's L/EA, plus 1/k
    /// of a compliant latch in series with it.
    pub fn latched_sleeve_compliance_m_per_n(&self, e: usize) -> f64 {
        let el = &self.elements[e];
        let mut tube = [f64::NAN];
        el.row_compliance_m_per_n(true, self.axial_stiffness_n, &mut tube);
        tube[0] + el.latch_spring().map_or(0.0, |(k, _)| 1.0 / k)
    }

    pub fn n_joints(&self) -> usize {
        self.joints.len()
    }
    pub fn n_coords(&self) -> usize {
        3 * self.joints.len()
    }
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }
    pub fn cable_index(&self, name: &str) -> Option<usize> {
        self.cables.iter().position(|c| c.name == name)
    }
    /// Largest extent of the reference geometry along x, y or z (m).
    pub fn reference_size_m(&self) -> Option<f64> {
        let r = self.reference.as_ref()?;
        let mut size: f64 = 0.0;
        for axis in 0..3 {
            let vals = r.iter().skip(axis).step_by(3);
            let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
            size = size.max(hi - lo);
        }
        Some(size)
    }
    /// The motors' work of a deployment from X0 to the reference geometry
    /// at their starting tensions: sum over cables of T (L(X0) - L(ref)) (J;
    /// 0 without a reference). The energy scale a whole run reaches, known
    /// at the start.
    pub fn drive_work_to_reference_j(&self) -> f64 {
        let Some(r) = &self.reference else {
            return 0.0;
        };
        self.cables
            .iter()
            .map(|c| (c.tension_n * (c.length_m(&self.x0) - c.length_m(r))).abs())
            .sum()
    }

    /// The first element row whose residual at X0 exceeds `tol` (m), as
    /// (element, row, residual). Sleeves are checked only if they start latched.
    pub fn initial_violation(&self, tol: f64) -> Option<(usize, usize, f64)> {
        let mut buf = Vec::new();
        for (e, el) in self.elements.iter().enumerate() {
            let starts_locked = el
                .lock_gap(&self.x0)
                .is_some_and(|g| g.abs() <= self.solver.lock_tol_m);
            let rows = el.rows(starts_locked);
            buf.resize(rows, 0.0);
            if rows == 0 {
                continue;
            }
            el.residual(&self.x0, &mut buf);
            if let Some(r) = buf.iter().position(|v| !(v.abs() <= tol)) {
                return Some((e, r, buf[r]));
            }
        }
        None
    }

    /// Total active rows with the given locked set.
    pub fn active_rows(&self, locked: &[bool]) -> usize {
        self.elements
            .iter()
            .zip(locked)
            .map(|(e, l)| e.rows(*l))
            .sum()
    }
}

/// The first element at which the constraint Jacobian, every element with
/// its most entries (`Jacobian::most_entries`), holds more than `limit`:
/// `Jacobian::pattern` indexes its values with u32, so a built model's
/// Jacobian always fits.
fn first_over_jacobian_limit(elems: &[Box<dyn Constraint>], limit: usize) -> Option<usize> {
    let mut entries = 0usize;
    for (i, e) in elems.iter().enumerate() {
        entries = entries.saturating_add(Jacobian::most_entries(e.as_ref()));
        if entries > limit {
            return Some(i);
        }
    }
    None
}

/// A model the solver cannot build (`Model::build`): which part, and what is
/// wrong with it (the model-file layer adds the file and the line).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelError {
    pub at: ModelPart,
    pub what: String,
}

/// Where in a model an error is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelPart {
    /// The joints (their positions, masses or reference positions).
    Joints,
    /// The element of this index.
    Element(usize),
    /// The cable of this index.
    Cable(usize),
    /// The model-wide settings (step, end time, damping, gravity, stiffness).
    Settings,
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.what)
    }
}

impl std::error::Error for ModelError {}

#[cfg(test)]
mod tests {
    use super::{first_over_jacobian_limit, Jacobian};
    use crate::model::generate::{self, MastParams};

    /// The limit check counts what `Jacobian::pattern` stores with every
    /// element locked or unlocked, whichever has more rows, and names the
    /// element that passes it.
    #[test]
    fn the_jacobian_limit_is_passed_where_its_entries_are() {
        let text = generate::mast(&MastParams::default()).unwrap().to_toml();
        let m = crate::model::parse(&text, "mast.toml").unwrap().model;
        let most = |locked: bool| {
            let jac = Jacobian::pattern(&m, &vec![locked; m.elements.len()]);
            jac.values.len()
        };
        let bound = m
            .elements
            .iter()
            .map(|e| Jacobian::most_entries(e.as_ref()))
            .sum::<usize>();
        assert!(bound >= most(true).max(most(false)));
        assert_eq!(first_over_jacobian_limit(&m.elements, bound), None);
        let last = m.elements.len() - 1;
        assert!(Jacobian::most_entries(m.elements[last].as_ref()) > 0);
        assert_eq!(
            first_over_jacobian_limit(&m.elements, bound - 1),
            Some(last)
        );
        assert_eq!(first_over_jacobian_limit(&m.elements, 0), Some(0));
    }
}
