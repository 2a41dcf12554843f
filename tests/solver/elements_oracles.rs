//! Oracle tests for the constraint macroelements, the mobility analysis and the
//! drive-cable model. Every expected value below comes from an independent
//! computation (finite differences, closed-form capstan law, Maxwell's rule, or
//! hand-derived geometry), never from a previous run of the code under test.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use truss_deploy::solver::cable::{self, CableEval};
use truss_deploy::solver::elements::{self, Constraint, ElementSpec, Param, REGISTRY};
use truss_deploy::solver::jacobian::Jacobian;
use truss_deploy::solver::mobility::{self, Mobility};
use truss_deploy::solver::{Cable, Joint, Model, ModelParts};

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// Tolerance of the finite-difference checks (relative to max(|value|_max, 1)).
const FD_TOL: f64 = 1e-6;
/// Step of the central differences of the residual (Jacobian check).
const JAC_STEP: f64 = 1e-6;
/// Step of the 5-point second-derivative formula (convective-term check).
const HESS_STEP: f64 = 1e-4;
/// Number of random configurations per element.
const N_CONFIGS: usize = 6;
/// Tolerance of the closed-form cable checks.
const CABLE_TOL: f64 = 1e-12;

/// Small deterministic PRNG (xorshift64*), so that no crate is needed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [-1, 1).
    fn sym(&mut self) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * u - 1.0
    }
    fn vec(&mut self, n: usize, amplitude: f64) -> Vec<f64> {
        (0..n).map(|_| amplitude * self.sym()).collect()
    }
}

fn spec(kind: &str, joints: &[usize], params: &[(&str, Param)]) -> ElementSpec {
    ElementSpec {
        kind: kind.to_string(),
        name: format!("{kind}_under_test"),
        joints: joints.to_vec(),
        params: params
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect::<BTreeMap<_, _>>(),
    }
}

fn num(v: f64) -> Param {
    Param::Num(v)
}

fn text(s: &str) -> Param {
    Param::Text(s.to_string())
}

/// Places joint positions into X at the given joint indices; `n_joints` may exceed
/// the number of positions (spare joints are placed away from the element).
fn layout(n_joints: usize, placed: &[(usize, [f64; 3])]) -> Vec<f64> {
    let mut x = vec![0.0; 3 * n_joints];
    for j in 0..n_joints {
        // Spare joints get some distinct non-zero position.
        x[3 * j] = 5.0 + j as f64;
        x[3 * j + 1] = -3.0 + 0.5 * j as f64;
        x[3 * j + 2] = 2.0;
    }
    for (j, p) in placed {
        x[3 * j..3 * j + 3].copy_from_slice(p);
    }
    x
}

fn norm3(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn pos(x: &[f64], j: usize) -> [f64; 3] {
    [x[3 * j], x[3 * j + 1], x[3 * j + 2]]
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, a| m.max(a.abs()))
}

/// A valid element geometry: the spec, the initial positions X0 it is built on,
/// and a typical length for the random perturbations.
struct Fixture {
    label: &'static str,
    spec: ElementSpec,
    x0: Vec<f64>,
    size: f64,
}

impl Fixture {
    fn build(&self) -> Box<dyn Constraint> {
        elements::build(&self.spec, &self.x0)
            .unwrap_or_else(|e| panic!("{}: build failed: {e}", self.label))
    }
}

/// Joint indices are deliberately shuffled and a spare joint is present, so that
/// the column mapping of each element is exercised too.
fn bar_fixture() -> Fixture {
    let x0 = layout(3, &[(2, [0.1, -0.2, 0.3]), (0, [1.3, 0.7, -0.4])]);
    Fixture {
        label: "bar",
        spec: spec("bar", &[2, 0], &[]),
        x0,
        size: 1.0,
    }
}

fn sleeve_fixture() -> Fixture {
    // |(3,4,0)| = 5 exactly, so lock_length_m = 5 makes the latched row vanish at X0.
    let x0 = layout(3, &[(1, [0.0, 0.0, 0.0]), (2, [3.0, 4.0, 0.0])]);
    Fixture {
        label: "sleeve (locked)",
        spec: spec("sleeve", &[1, 2], &[("lock_length_m", num(5.0))]),
        x0,
        size: 3.0,
    }
}

/// Rectangle diagonals crossing at their midpoints (ratio 1), tilted out of the xy plane.
fn scissor_ratio1_fixture() -> Fixture {
    let x0 = layout(
        5,
        &[
            (3, [0.0, 0.0, 0.0]),
            (1, [2.0, 1.0, 0.5]),
            (4, [0.0, 1.0, 0.0]),
            (0, [2.0, 0.0, 0.5]),
        ],
    );
    Fixture {
        label: "scissor ratio 1",
        spec: spec("scissor", &[3, 1, 4, 0], &[]),
        x0,
        size: 1.5,
    }
}

/// Rods through the origin O with |Oj| = 2 |Oi| and |Ol| = 2 |Ok|, so that
/// O = (1 - t) X_i + t X_j with t = 1/3 on both rods.
fn scissor_ratio2_fixture() -> Fixture {
    let u = [0.8, 0.6, 0.0];
    let w = [0.0, 0.6, 0.8];
    let a = 0.7;
    let b = 0.9;
    let x0 = layout(
        4,
        &[
            (0, [-a * u[0], -a * u[1], -a * u[2]]),
            (1, [2.0 * a * u[0], 2.0 * a * u[1], 2.0 * a * u[2]]),
            (2, [-b * w[0], -b * w[1], -b * w[2]]),
            (3, [2.0 * b * w[0], 2.0 * b * w[1], 2.0 * b * w[2]]),
        ],
    );
    Fixture {
        label: "scissor ratio 2",
        spec: spec("scissor", &[0, 1, 2, 3], &[("ratio", num(2.0))]),
        x0,
        size: 1.5,
    }
}

/// Angulated rods i-o-j and k-o-l, all five points in the plane z = 0.3.
fn angulated_points() -> [[f64; 3]; 5] {
    [
        [-1.0, 0.3, 0.3],  // i
        [0.0, 0.0, 0.3],   // o
        [1.0, 0.3, 0.3],   // j
        [-1.1, -0.2, 0.3], // k
        [0.7, -0.5, 0.3],  // l
    ]
}

fn angulated_fixture() -> Fixture {
    let p = angulated_points();
    // joints [i, o, j, k, l] = [4, 0, 2, 5, 1]; joint 3 is spare.
    let idx = [4, 0, 2, 5, 1];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(p).collect();
    let x0 = layout(6, &placed);
    Fixture {
        label: "angulated_scissor",
        spec: spec("angulated_scissor", &idx, &[]),
        x0,
        size: 1.0,
    }
}

fn flat_square() -> [[f64; 3]; 4] {
    [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]
}

fn plate_fixture(formulation: Option<&'static str>) -> Fixture {
    let p = flat_square();
    let idx = [1, 3, 0, 2];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(p).collect();
    let x0 = layout(5, &placed);
    let params: Vec<(&str, Param)> = formulation
        .map(|f| vec![("formulation", text(f))])
        .unwrap_or_default();
    Fixture {
        label: match formulation {
            Some("six_bars") => "plate six_bars",
            _ => "plate flat",
        },
        spec: spec("plate", &idx, &params),
        x0,
        size: 1.0,
    }
}

fn coplanar_fixture() -> Fixture {
    let p = flat_square();
    let idx = [2, 0, 3, 1];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(p).collect();
    let x0 = layout(5, &placed);
    Fixture {
        label: "coplanar",
        spec: spec("coplanar", &idx, &[]),
        x0,
        size: 1.0,
    }
}

fn perpendicular_fixture() -> Fixture {
    // corner p at the origin, q up the post, r along the radial member
    let pts = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.7, 0.1, 0.0]];
    let idx = [3, 1, 0];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    let x0 = layout(5, &placed);
    Fixture {
        label: "perpendicular",
        spec: spec("perpendicular", &idx, &[]),
        x0,
        size: 1.0,
    }
}

fn sync_hinge_fixture(mirror: &'static str) -> Fixture {
    // hinge p, post end q above it, radial end r, chord ends a and b mirrored
    let pts = [
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 0.5],
        [1.3, 0.0, 0.0],
        [1.9, -0.8, 0.2],
        [1.9, 0.8, 0.2],
    ];
    let idx = [5, 2, 0, 4, 1];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    let x0 = layout(7, &placed);
    Fixture {
        label: match mirror {
            "axial" => "sync_hinge axial",
            "radial" => "sync_hinge radial",
            _ => "sync_hinge both",
        },
        spec: spec("sync_hinge", &idx, &[("mirror", text(mirror))]),
        x0,
        size: 1.0,
    }
}

/// |(3,4,0)| = 5: the stroke [4.99, 5.0] m puts X0 at its long end, so the
/// random configurations press both ends of the stroke and leave it free.
fn end_stop_fixture() -> Fixture {
    let x0 = layout(3, &[(1, [0.0, 0.0, 0.0]), (2, [3.0, 4.0, 0.0])]);
    Fixture {
        label: "end_stop",
        spec: spec(
            "end_stop",
            &[1, 2],
            &[
                ("min_length_m", num(4.99)),
                ("max_length_m", num(5.0)),
                ("stiffness_n_per_m", num(1e4)),
            ],
        ),
        x0,
        size: 3.0,
    }
}

fn centroid_fixture() -> Fixture {
    let pts = [[1.0, 0.0, 0.2], [0.0, 1.0, -0.2], [-1.0, 0.1, 0.3]];
    let idx = [4, 0, 2];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    let x0 = layout(5, &placed);
    Fixture {
        label: "centroid",
        spec: spec("centroid", &idx, &[("fix", text("xz"))]),
        x0,
        size: 1.0,
    }
}

fn rigid_body_fixture() -> Fixture {
    // an octahedron's +x, -x, +y, +z, then -y, -z and two mount points
    let pts = [
        [0.5, 0.0, 0.0],
        [-0.5, 0.0, 0.0],
        [0.0, 0.5, 0.0],
        [0.0, 0.0, 0.5],
        [0.0, -0.5, 0.0],
        [0.0, 0.0, -0.5],
        [1.2, 0.1, 0.3],
        [1.1, -0.2, 0.9],
    ];
    let idx = [0, 1, 2, 3, 4, 5, 6, 7];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    Fixture {
        label: "rigid_body",
        spec: spec("rigid_body", &idx, &[]),
        x0: layout(8, &placed),
        size: 1.0,
    }
}

fn hinge_axis_fixture() -> Fixture {
    // hinge p, post end q above it, radial member end r square to the post, chord end a
    let pts = [
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 0.5],
        [1.3, 0.0, 0.0],
        [1.9, 0.8, 0.2],
    ];
    let idx = [1, 4, 0, 3];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    let x0 = layout(6, &placed);
    Fixture {
        label: "hinge_axis",
        spec: spec("hinge_axis", &idx, &[]),
        x0,
        size: 1.0,
    }
}

fn frame_hinge_fixture() -> Fixture {
    // hinge p, post end q above it, frame member end r sheared 40 deg from square
    // (a parallelogram frame), chord end a
    let (sp, cp) = 40f64.to_radians().sin_cos();
    let pts = [
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 0.5],
        [2.0 - 0.7 * cp, 0.0, 0.7 * sp],
        [1.9, 0.8, 0.2],
    ];
    let idx = [1, 4, 0, 3];
    let placed: Vec<(usize, [f64; 3])> = idx.iter().copied().zip(pts).collect();
    let x0 = layout(6, &placed);
    Fixture {
        label: "frame_hinge",
        spec: spec("frame_hinge", &idx, &[]),
        x0,
        size: 1.0,
    }
}

fn support_fixture(fix: &'static str) -> Fixture {
    let x0 = layout(3, &[(1, [0.4, -0.7, 1.1])]);
    Fixture {
        label: "support",
        spec: spec("support", &[1], &[("fix", text(fix))]),
        x0,
        size: 1.0,
    }
}

/// One fixture per registry entry (and per plate formulation / scissor ratio).
fn all_fixtures() -> Vec<Fixture> {
    vec![
        bar_fixture(),
        sleeve_fixture(),
        scissor_ratio1_fixture(),
        scissor_ratio2_fixture(),
        angulated_fixture(),
        plate_fixture(None),
        plate_fixture(Some("six_bars")),
        coplanar_fixture(),
        perpendicular_fixture(),
        centroid_fixture(),
        rigid_body_fixture(),
        hinge_axis_fixture(),
        frame_hinge_fixture(),
        sync_hinge_fixture("both"),
        sync_hinge_fixture("axial"),
        sync_hinge_fixture("radial"),
        end_stop_fixture(),
        support_fixture("xz"),
        support_fixture("xyz"),
    ]
}

/// All elements are evaluated as active (sleeves latched).
fn rows(el: &dyn Constraint) -> usize {
    // (a compliant element imposes none; its spring's rows are its residual)
    el.spring().map_or(el.rows(true), |s| s.rows)
}

fn residual(el: &dyn Constraint, x: &[f64]) -> Vec<f64> {
    let mut out = vec![f64::NAN; rows(el)];
    el.residual(x, &mut out);
    out
}

/// Random configurations around X0 (the residual is not zero there; the
/// derivative identities hold anywhere).
fn random_configs(f: &Fixture, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = Rng::new(seed);
    (0..N_CONFIGS)
        .map(|_| {
            let d = rng.vec(f.x0.len(), 0.15 * f.size);
            f.x0.iter().zip(d).map(|(a, b)| a + b).collect()
        })
        .collect()
}

/// (a) The element Jacobian against central differences of its residual, and
/// zero derivative with respect to joints the element does not name.
fn check_jacobian_fd(f: &Fixture, seed: u64) {
    let el = f.build();
    let r = rows(el.as_ref());
    assert!(r > 0, "{}: no rows", f.label);
    let js = el.joints().to_vec();
    let w = 3 * js.len();
    for (n, x) in random_configs(f, seed).iter().enumerate() {
        let mut jac = vec![f64::NAN; r * w];
        el.jacobian(x, &mut jac);
        assert!(
            jac.iter().all(|v| v.is_finite()),
            "{} config {n}: the Jacobian leaves entries unwritten or non-finite: {jac:?}",
            f.label
        );
        let scale = max_abs(&jac).max(1.0);
        for coord in 0..x.len() {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[coord] += JAC_STEP;
            xm[coord] -= JAC_STEP;
            let (rp, rm) = (residual(el.as_ref(), &xp), residual(el.as_ref(), &xm));
            let joint = coord / 3;
            let column = js
                .iter()
                .position(|&j| j == joint)
                .map(|m| 3 * m + coord % 3);
            for row in 0..r {
                let fd = (rp[row] - rm[row]) / (2.0 * JAC_STEP);
                let analytic = column.map_or(0.0, |c| jac[row * w + c]);
                let err = (analytic - fd).abs() / scale;
                assert!(
                    err < FD_TOL,
                    "{} config {n}: dPhi[{row}]/dX[{coord}] analytic {analytic:.12e} vs FD {fd:.12e} (rel err {err:.3e})",
                    f.label
                );
                // a row that says it does not touch the joint has exact
                // zeros there, and no derivative there either
                if let Some(c) = column {
                    if !el.row_touches(true, row, c / 3) {
                        assert!(
                            analytic == 0.0 && fd.abs() / scale < FD_TOL,
                            "{} config {n}: row {row} is said not to touch joint {} but \
                             dPhi/dX[{coord}] is {analytic:e} (FD {fd:e})",
                            f.label,
                            c / 3
                        );
                    }
                }
            }
        }
    }
}

/// Second directional derivative d2/ds2 Phi(x + s v) at s = 0 by the 5-point
/// central formula (truncation O(h^4)).
fn second_directional_fd(el: &dyn Constraint, x: &[f64], v: &[f64]) -> Vec<f64> {
    let h = HESS_STEP;
    let g = |s: f64| -> Vec<f64> {
        let xs: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + s * b).collect();
        residual(el, &xs)
    };
    let (g2m, g1m, g0, g1p, g2p) = (g(-2.0 * h), g(-h), g(0.0), g(h), g(2.0 * h));
    (0..g0.len())
        .map(|r| (-g2p[r] + 16.0 * g1p[r] - 30.0 * g0[r] + 16.0 * g1m[r] - g2m[r]) / (12.0 * h * h))
        .collect()
}

/// (b) The convective term (dA/dt) Xdot = v^T Hess(Phi) v against the second
/// directional derivative. Returns the largest |adot_xdot| seen (for
/// non-triviality checks).
fn check_convective_fd(f: &Fixture, seed: u64) -> f64 {
    let el = f.build();
    let r = rows(el.as_ref());
    let mut rng = Rng::new(seed ^ 0xABCD);
    let mut largest: f64 = 0.0;
    for (n, x) in random_configs(f, seed).iter().enumerate() {
        let v = rng.vec(x.len(), 1.0);
        let mut out = vec![f64::NAN; r];
        el.adot_xdot(x, &v, &mut out);
        assert!(
            out.iter().all(|a| a.is_finite()),
            "{} config {n}: adot_xdot leaves entries unwritten or non-finite: {out:?}",
            f.label
        );
        let fd = second_directional_fd(el.as_ref(), x, &v);
        let scale = max_abs(&out).max(1.0);
        for row in 0..r {
            let err = (out[row] - fd[row]).abs() / scale;
            assert!(
                err < FD_TOL,
                "{} config {n}: (Adot Xdot)[{row}] analytic {:.12e} vs v^T H v by FD {:.12e} (rel err {err:.3e})",
                f.label,
                out[row],
                fd[row]
            );
        }
        largest = largest.max(max_abs(&out));
    }
    largest
}

fn model(x0: Vec<f64>, specs: Vec<ElementSpec>) -> Model {
    let n = x0.len() / 3;
    let joints = (0..n)
        .map(|j| Joint {
            name: format!("j{j}"),
            mass_kg: 1.0 + 0.1 * j as f64,
        })
        .collect();
    Model::build(ModelParts {
        name: "oracle".into(),
        joints,
        x0,
        reference: None,
        elements: specs,
        cables: vec![],
        gravity_m_s2: [0.0; 3],
        damping_n_s_per_m: 0.0,
        dt_s: 1e-3,
        end_time_s: 1.0,
        axial_stiffness_n: None,
    })
    .unwrap_or_else(|e| panic!("model build failed at {:?}: {e}", e.at))
}

fn analyze_free(x0: Vec<f64>, specs: Vec<ElementSpec>) -> Mobility {
    let m = model(x0, specs);
    let locked = vec![false; m.elements.len()];
    mobility::analyze(&m, &m.x0, &locked)
}

fn assert_maxwell(m: &Mobility) {
    assert_eq!(
        m.mechanisms as i64 - m.self_stress as i64,
        m.coordinates as i64 - m.rows as i64,
        "extended Maxwell rule m - s = 3n - rows violated: {m:?}"
    );
    assert_eq!(m.mechanisms + m.rank, m.coordinates, "{m:?}");
    assert_eq!(m.self_stress + m.rank, m.rows, "{m:?}");
}

fn test_cable(path: Vec<usize>, mu: f64, rho: f64, radius: f64, slip: f64) -> Cable {
    Cable {
        name: "drive".into(),
        path,
        tension_n: 10.0,
        max_tension_n: 100.0,
        friction_mu: mu,
        line_density_kg_per_m: rho,
        pulley_radius_m: radius,
        slip_speed_m_s: slip,
    }
}

fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

/// Rate of change of |X_q - X_p| along the velocity v, computed directly.
fn length_rate(x: &[f64], v: &[f64], p: usize, q: usize) -> f64 {
    let d = sub3(pos(x, q), pos(x, p));
    let w = sub3(pos(v, q), pos(v, p));
    (d[0] * w[0] + d[1] * w[1] + d[2] * w[2]) / norm3(d)
}

/// Motor joint 0, pulley joint 1 at the origin, anchor joint 2; the segments meet
/// at the pulley at the angle 2 beta.
fn vee_geometry(beta: f64) -> Vec<f64> {
    let (c, s) = (beta.cos(), beta.sin());
    let (l0, l1) = (1.3, 0.8);
    vec![l0 * c, l0 * s, 0.0, 0.0, 0.0, 0.0, l1 * c, -l1 * s, 0.0]
}

// ---------------------------------------------------------------------------
// 1. Element derivatives by finite differences
// ---------------------------------------------------------------------------

#[test]
fn every_registry_type_has_a_fixture() {
    let fixtures = all_fixtures();
    for (kind, _, _, _) in REGISTRY {
        assert!(
            fixtures.iter().any(|f| f.spec.kind == *kind),
            "element type `{kind}` is in the registry but has no finite-difference fixture"
        );
    }
    // Both plate formulations are covered.
    let plate_forms: Vec<_> = fixtures
        .iter()
        .filter(|f| f.spec.kind == "plate")
        .map(|f| f.spec.params.get("formulation").cloned())
        .collect();
    assert!(plate_forms.contains(&None) && plate_forms.contains(&Some(text("six_bars"))));
}

#[test]
fn residuals_vanish_on_the_build_geometry() {
    for f in all_fixtures() {
        let el = f.build();
        let r = residual(el.as_ref(), &f.x0);
        assert!(
            max_abs(&r) < 1e-12,
            "{}: residual at the initial geometry is {r:?}",
            f.label
        );
    }
}

#[test]
fn row_counts_match_the_documented_element_rows() {
    let expected = [
        ("bar", 1),
        ("sleeve (locked)", 1),
        ("scissor ratio 1", 6),
        ("scissor ratio 2", 6),
        ("angulated_scissor", 8),
        ("plate flat", 6),
        ("plate six_bars", 6),
        ("coplanar", 1),
        ("perpendicular", 1),
        ("centroid", 2),
        ("rigid_body", 3 * 8 - 6),
        ("hinge_axis", 1),
        ("frame_hinge", 1),
        ("sync_hinge both", 2),
        ("sync_hinge axial", 1),
        ("sync_hinge radial", 1),
        ("end_stop", 1),
    ];
    let fixtures = all_fixtures();
    for (label, n) in expected {
        let f = fixtures.iter().find(|f| f.label == label).unwrap();
        assert_eq!(rows(f.build().as_ref()), n, "{label}");
    }
    // A sleeve imposes nothing until it latches.
    assert_eq!(sleeve_fixture().build().rows(false), 0);
    assert_eq!(support_fixture("xz").build().rows(true), 2);
    assert_eq!(support_fixture("xyz").build().rows(true), 3);
}

#[test]
fn bar_derivatives_match_finite_differences() {
    let f = bar_fixture();
    check_jacobian_fd(&f, 11);
    assert!(check_convective_fd(&f, 12) > 1e-3);
}

#[test]
fn locked_sleeve_derivatives_match_finite_differences() {
    let f = sleeve_fixture();
    check_jacobian_fd(&f, 21);
    assert!(check_convective_fd(&f, 22) > 1e-3);
}

#[test]
fn scissor_ratio_one_derivatives_match_finite_differences() {
    let f = scissor_ratio1_fixture();
    check_jacobian_fd(&f, 31);
    assert!(check_convective_fd(&f, 32) > 1e-3);
}

#[test]
fn scissor_ratio_two_derivatives_match_finite_differences() {
    let f = scissor_ratio2_fixture();
    check_jacobian_fd(&f, 41);
    assert!(check_convective_fd(&f, 42) > 1e-3);
}

#[test]
fn angulated_scissor_derivatives_match_finite_differences() {
    let f = angulated_fixture();
    check_jacobian_fd(&f, 51);
    assert!(check_convective_fd(&f, 52) > 1e-3);
}

#[test]
fn flat_plate_derivatives_match_finite_differences() {
    let f = plate_fixture(None);
    check_jacobian_fd(&f, 61);
    assert!(check_convective_fd(&f, 62) > 1e-3);
}

#[test]
fn six_bar_plate_derivatives_match_finite_differences() {
    let f = plate_fixture(Some("six_bars"));
    check_jacobian_fd(&f, 71);
    assert!(check_convective_fd(&f, 72) > 1e-3);
}

/// The end stop's overrun max(0, l - L_max) + min(0, l - L_min) has the
/// Jacobian [-e, e] where engaged and 0 where free: central differences agree
/// at configurations on both sides of the stroke and inside it (the kink
/// itself is not sampled). Its Adot Xdot is 0 (a spring row, never imposed).
#[test]
fn end_stop_derivatives_match_finite_differences() {
    let f = end_stop_fixture();
    let el = f.build();
    let (mut long, mut short, mut free) = (0, 0, 0);
    for x in (91..101).flat_map(|seed| {
        check_jacobian_fd(&f, seed);
        random_configs(&f, seed)
    }) {
        let r = residual(el.as_ref(), &x)[0];
        match r {
            r if r > 0.0 => long += 1,
            r if r < 0.0 => short += 1,
            _ => free += 1,
        }
    }
    assert!(
        long > 0 && short > 0,
        "long {long}, short {short}, free {free}"
    );
}

/// A rigid body's 3k - 6 distance rows: finite differences agree, and they
/// leave exactly the six rigid motions (rank 3k - 6 at its geometry).
#[test]
fn rigid_body_derivatives_match_finite_differences() {
    let f = rigid_body_fixture();
    check_jacobian_fd(&f, 111);
    assert!(check_convective_fd(&f, 112) > 1e-3);
    let el = f.build();
    let m = model(f.x0.clone(), vec![f.spec.clone()]);
    let mut jac = Jacobian::pattern(&m, &vec![false; 1]);
    jac.fill(&m, &f.x0);
    let sv = jac.to_dense().singular_values();
    let rank = sv.iter().filter(|s| **s > 1e-9 * sv.max()).count();
    assert_eq!(rank, 3 * 8 - 6, "{}", el.name());
}

#[test]
fn support_derivatives_match_finite_differences() {
    for fix in ["xz", "xyz", "y"] {
        let f = support_fixture(fix);
        check_jacobian_fd(&f, 81);
        // Linear rows: the convective term must vanish (checked against FD too).
        assert_eq!(check_convective_fd(&f, 82), 0.0, "support fix = {fix}");
    }
}

#[test]
fn assembled_jacobian_matches_finite_differences_and_products() {
    // An SLE, a bar from its pivot-side joint to a fifth joint and a support.
    let mut x0 = scissor_ratio1_fixture().x0;
    x0.truncate(15); // joints 0..5 (joint 2 is the spare one)
    let specs = vec![
        spec("scissor", &[3, 1, 4, 0], &[]),
        spec("bar", &[1, 2], &[]),
        spec("support", &[3], &[("fix", text("xyz"))]),
        spec("plate", &[0, 1, 2, 4], &[("formulation", text("six_bars"))]),
    ];
    let m = model(x0, specs);
    let locked = vec![false; m.elements.len()];
    let mut jac = Jacobian::pattern(&m, &locked);
    assert_eq!(jac.nrows, 6 + 1 + 3 + 6);
    assert_eq!(jac.ncols, 15);
    let mut rng = Rng::new(91);
    for _ in 0..N_CONFIGS {
        let x: Vec<f64> = m.x0.iter().map(|a| a + 0.1 * rng.sym()).collect();
        jac.fill(&m, &x);
        let dense = jac.to_dense();
        let scale = dense.amax().max(1.0);
        let res = |x: &[f64]| {
            let mut out = vec![0.0; jac.nrows];
            jac.residual(&m, x, &mut out);
            out
        };
        for c in 0..jac.ncols {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[c] += JAC_STEP;
            xm[c] -= JAC_STEP;
            let (rp, rm) = (res(&xp), res(&xm));
            for r in 0..jac.nrows {
                let fd = (rp[r] - rm[r]) / (2.0 * JAC_STEP);
                assert!(
                    (dense[(r, c)] - fd).abs() / scale < FD_TOL,
                    "A[{r},{c}] = {} vs FD {fd}",
                    dense[(r, c)]
                );
            }
        }
        // A v and A^T y against the dense matrix.
        let v = rng.vec(jac.ncols, 1.0);
        let y = rng.vec(jac.nrows, 1.0);
        let mut av = vec![0.0; jac.nrows];
        let mut aty = vec![0.0; jac.ncols];
        jac.mul(&v, &mut av);
        jac.mul_t(&y, &mut aty);
        let dv = &dense * nalgebra::DVector::from_vec(v.clone());
        let dy = dense.transpose() * nalgebra::DVector::from_vec(y.clone());
        for r in 0..jac.nrows {
            assert!((av[r] - dv[r]).abs() < 1e-12 * scale * 16.0);
        }
        for c in 0..jac.ncols {
            assert!((aty[c] - dy[c]).abs() < 1e-12 * scale * 16.0);
        }
        // Assembled convective term against v^T H v by FD.
        let mut adot = vec![0.0; jac.nrows];
        jac.adot_xdot(&m, &x, &v, &mut adot);
        let h = HESS_STEP;
        let g = |s: f64| {
            let xs: Vec<f64> = x.iter().zip(&v).map(|(a, b)| a + s * b).collect();
            res(&xs)
        };
        let (g2m, g1m, g0, g1p, g2p) = (g(-2.0 * h), g(-h), g(0.0), g(h), g(2.0 * h));
        let ascale = max_abs(&adot).max(1.0);
        for r in 0..jac.nrows {
            let fd =
                (-g2p[r] + 16.0 * g1p[r] - 30.0 * g0[r] + 16.0 * g1m[r] - g2m[r]) / (12.0 * h * h);
            assert!(
                (adot[r] - fd).abs() / ascale < FD_TOL,
                "assembled Adot Xdot row {r}: {} vs FD {fd}",
                adot[r]
            );
        }
    }
}

// ---------------------------------------------------------------------------
// 2. Degrees of freedom by rank
// ---------------------------------------------------------------------------

#[test]
fn mobility_of_a_free_bar_is_five() {
    let x0 = vec![0.0, 0.0, 0.0, 0.6, -0.8, 0.4];
    let m = analyze_free(x0, vec![spec("bar", &[0, 1], &[])]);
    assert_eq!((m.coordinates, m.rows, m.rank), (6, 1, 1), "{m:?}");
    assert_eq!(m.mechanisms, 5, "{m:?}");
    assert_eq!(m.self_stress, 0, "{m:?}");
    assert_maxwell(&m);
}

#[test]
fn mobility_of_a_free_scissor_link_is_seven_with_one_self_stress() {
    // Ratio 1: rectangle diagonals (tilted); ratio 2: the fixture geometry.
    let rect = vec![
        0.0, 0.0, 0.0, //
        2.0, 1.0, 0.5, //
        0.0, 1.0, 0.0, //
        2.0, 0.0, 0.5,
    ];
    let r2 = scissor_ratio2_fixture();
    for (x0, s) in [
        (rect, spec("scissor", &[0, 1, 2, 3], &[])),
        (r2.x0.clone(), r2.spec.clone()),
    ] {
        let m = analyze_free(x0, vec![s]);
        assert_eq!(m.coordinates, 12, "{m:?}");
        assert_eq!(m.rows, 6, "{m:?}");
        assert_eq!(m.rank, 5, "{m:?}");
        assert_eq!(m.mechanisms, 7, "{m:?}");
        assert_eq!(m.self_stress, 1, "{m:?}");
        assert_eq!(m.redundant_rows.len(), 1, "{m:?}");
        assert_maxwell(&m);
    }
}

#[test]
fn mobility_of_a_free_angulated_scissor_is_seven_at_full_rank() {
    let x0: Vec<f64> = angulated_points().iter().flatten().copied().collect();
    let m = analyze_free(x0, vec![spec("angulated_scissor", &[0, 1, 2, 3, 4], &[])]);
    assert_eq!(m.coordinates, 15, "{m:?}");
    assert_eq!(m.rows, 8, "{m:?}");
    assert_eq!(m.rank, 8, "{m:?}");
    assert_eq!(m.mechanisms, 7, "{m:?}");
    assert_eq!(m.self_stress, 0, "{m:?}");
    assert!(m.redundant_rows.is_empty(), "{m:?}");
    assert_maxwell(&m);
}

#[test]
fn mobility_of_a_free_flat_plate_is_six_with_the_default_formulation() {
    let x0: Vec<f64> = flat_square().iter().flatten().copied().collect();
    let m = analyze_free(x0, vec![spec("plate", &[0, 1, 2, 3], &[])]);
    assert_eq!((m.coordinates, m.rows, m.rank), (12, 6, 6), "{m:?}");
    assert_eq!(m.mechanisms, 6, "{m:?}");
    assert_eq!(m.self_stress, 0, "{m:?}");
    assert_maxwell(&m);
}

#[test]
fn mobility_of_a_flat_six_bar_plate_shows_the_infinitesimal_mechanism() {
    let x0: Vec<f64> = flat_square().iter().flatten().copied().collect();
    let m = analyze_free(
        x0,
        vec![spec(
            "plate",
            &[0, 1, 2, 3],
            &[("formulation", text("six_bars"))],
        )],
    );
    assert_eq!((m.coordinates, m.rows, m.rank), (12, 6, 5), "{m:?}");
    assert_eq!(m.mechanisms, 7, "{m:?}");
    assert_eq!(m.self_stress, 1, "{m:?}");
    assert_maxwell(&m);
}

#[test]
fn mobility_of_a_twisted_six_bar_quadrilateral_is_six() {
    let x0 = vec![
        0.0, 0.0, 0.0, //
        1.0, 0.0, 0.0, //
        1.0, 1.0, 0.3, //
        0.0, 1.0, 0.0,
    ];
    let m = analyze_free(
        x0,
        vec![spec(
            "plate",
            &[0, 1, 2, 3],
            &[("formulation", text("six_bars"))],
        )],
    );
    assert_eq!((m.coordinates, m.rows, m.rank), (12, 6, 6), "{m:?}");
    assert_eq!(m.mechanisms, 6, "{m:?}");
    assert_eq!(m.self_stress, 0, "{m:?}");
    assert_maxwell(&m);
}

// ---------------------------------------------------------------------------
// 3. Capstan law
// ---------------------------------------------------------------------------

#[test]
fn capstan_ratio_follows_the_sliding_direction() {
    let c = test_cable(vec![0, 1, 2], 0.3, 0.0, 0.05, 1e-3);
    let t = 40.0;
    // Reeling in: the cable slides toward the motor, far side is the slack side.
    let toward = cable::across_pulley(&c, t, PI, 0.5, 0.0);
    assert!(
        rel_close(toward, t * (-0.3 * PI).exp(), CABLE_TOL),
        "toward motor: {toward} vs {}",
        t * (-0.3 * PI).exp()
    );
    // Paying out: friction opposes the other way, far side carries more.
    let away = cable::across_pulley(&c, t, PI, -0.5, 0.0);
    assert!(
        rel_close(away, t * (0.3 * PI).exp(), CABLE_TOL),
        "away from motor: {away} vs {}",
        t * (0.3 * PI).exp()
    );
    assert!(toward < t && away > t);
}

#[test]
fn capstan_ratio_is_continuous_through_zero_sliding() {
    let slip = 2e-3;
    let c = test_cable(vec![0, 1, 2], 0.3, 0.0, 0.05, slip);
    let t = 25.0;
    assert_eq!(cable::across_pulley(&c, t, PI, 0.0, 0.0), t);
    let half = cable::across_pulley(&c, t, PI, 0.5 * slip, 0.0);
    assert!(
        rel_close(half, t * (-0.3 * PI / 2.0).exp(), CABLE_TOL),
        "half the slip speed: {half}"
    );
    let half_back = cable::across_pulley(&c, t, PI, -0.5 * slip, 0.0);
    assert!(rel_close(half_back, t * (0.3 * PI / 2.0).exp(), CABLE_TOL));
    // Saturation: at and beyond the slip speed the full capstan ratio applies.
    for s in [slip, 10.0 * slip] {
        let full = cable::across_pulley(&c, t, PI, s, 0.0);
        assert!(rel_close(full, t * (-0.3 * PI).exp(), CABLE_TOL));
    }
    // Monotone in the sliding speed across the blend.
    let mut prev = f64::INFINITY;
    for i in -10..=10 {
        let tf = cable::across_pulley(&c, t, PI, 0.15 * slip * i as f64, 0.0);
        assert!(tf <= prev, "far-side tension not monotone in sliding speed");
        prev = tf;
    }
}

#[test]
fn evaluate_gives_the_wrap_angle_and_capstan_direction_of_a_vee() {
    let beta = 0.6;
    let x = vee_geometry(beta);
    let mu = 0.3;
    let c = test_cable(vec![0, 1, 2], mu, 0.0, 0.05, 1e-3);
    let t = 30.0;
    // The anchor moves toward the pulley: the far segment shortens (reeled in).
    let speed = 0.2;
    let mut v = vec![0.0; 9];
    let a = pos(&x, 2);
    let la = norm3(a);
    for k in 0..3 {
        v[6 + k] = -speed * a[k] / la;
    }
    let mut ev = CableEval::for_cable(&c);
    cable::evaluate(&c, t, &x, &v, None, &mut ev);
    let wrap = PI - 2.0 * beta;
    assert!(
        (ev.wrap_rad[0] - wrap).abs() < CABLE_TOL,
        "wrap {} vs {wrap}",
        ev.wrap_rad[0]
    );
    assert!(rel_close(ev.sliding_m_s[0], speed, CABLE_TOL), "{ev:?}");
    assert!(rel_close(ev.segment_length_m[0], 1.3, CABLE_TOL));
    assert!(rel_close(ev.segment_length_m[1], 0.8, CABLE_TOL));
    assert!(rel_close(ev.length_m, 2.1, CABLE_TOL));
    assert_eq!(ev.segment_tension_n[0], t);
    let expect = t * (-mu * wrap).exp();
    assert!(
        rel_close(ev.segment_tension_n[1], expect, CABLE_TOL),
        "far tension {} vs {expect}",
        ev.segment_tension_n[1]
    );
    // Reverse the motion: the far segment lengthens, friction flips.
    let vr: Vec<f64> = v.iter().map(|a| -a).collect();
    cable::evaluate(&c, t, &x, &vr, None, &mut ev);
    assert!(rel_close(ev.sliding_m_s[0], -speed, CABLE_TOL));
    assert!(rel_close(
        ev.segment_tension_n[1],
        t * (mu * wrap).exp(),
        CABLE_TOL
    ));
}

#[test]
fn evaluate_accumulates_sliding_and_friction_over_several_pulleys() {
    // Path 0 -> 1 -> 2 -> 3 with two pulleys; every joint moves.
    let x = vec![
        0.0, 0.0, 0.0, //
        1.0, 0.2, 0.1, //
        1.5, 1.1, -0.2, //
        0.4, 1.8, 0.3,
    ];
    let mu = 0.25;
    let c = test_cable(vec![0, 1, 2, 3], mu, 0.0, 0.05, 1e-6);
    let mut rng = Rng::new(123);
    for _ in 0..N_CONFIGS {
        let v = rng.vec(12, 0.5);
        let mut ev = CableEval::for_cable(&c);
        cable::evaluate(&c, 50.0, &x, &v, None, &mut ev);
        let (dl1, dl2) = (length_rate(&x, &v, 1, 2), length_rate(&x, &v, 2, 3));
        let s1 = -(dl1 + dl2); // pulley at joint 1: everything beyond it
        let s2 = -dl2;
        assert!((ev.sliding_m_s[0] - s1).abs() < CABLE_TOL * s1.abs().max(1.0));
        assert!((ev.sliding_m_s[1] - s2).abs() < CABLE_TOL * s2.abs().max(1.0));
        // Wrap angles from the turning angle between consecutive segment directions.
        for (k, (p, q, r)) in [(0, 1, 2), (1, 2, 3)].into_iter().enumerate() {
            let d1 = sub3(pos(&x, q), pos(&x, p));
            let d2 = sub3(pos(&x, r), pos(&x, q));
            let turn =
                ((d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / (norm3(d1) * norm3(d2))).acos();
            assert!((ev.wrap_rad[k] - turn).abs() < 1e-12, "wrap {k}");
        }
        // Each pulley applies its own capstan factor with its own direction
        // (slip speed tiny, so the direction is saturated).
        let t1 = 50.0 * (-mu * s1.signum() * ev.wrap_rad[0]).exp();
        let t2 = t1 * (-mu * s2.signum() * ev.wrap_rad[1]).exp();
        assert!(rel_close(ev.segment_tension_n[1], t1, CABLE_TOL));
        assert!(rel_close(ev.segment_tension_n[2], t2, CABLE_TOL));
    }
}

/// Six joints in general position for a cable over four pulleys (path 0..=5).
fn four_pulley_path_x() -> Vec<f64> {
    vec![
        0.0, 0.0, 0.0, //
        1.0, 0.2, 0.1, //
        1.5, 1.1, -0.2, //
        0.4, 1.8, 0.3, //
        -0.3, 1.2, 0.9, //
        0.2, 0.4, 1.4,
    ]
}

/// The cable's readings at (x, v) with a 40 N motor, and its forces on the joints.
fn cable_forces_at(c: &Cable, x: &[f64], v: &[f64]) -> (Vec<f64>, CableEval) {
    let mut ev = CableEval::for_cable(c);
    cable::evaluate(c, 40.0, x, v, None, &mut ev);
    let mut q = vec![0.0; x.len()];
    cable::add_forces(c, &ev, x, &mut q);
    (q, ev)
}

/// The Newton steps of the Newmark iteration steer by the derivative of the
/// cable forces with respect to the joint velocities through the friction
/// direction's blend (`cable::add_friction_derivative`); oracle: central
/// differences of `evaluate` + `add_forces` along random velocity changes, at
/// velocities that put some pulleys inside the blend and some beyond it.
#[test]
fn friction_derivative_matches_finite_differences_of_the_forces() {
    let (x, path) = (four_pulley_path_x(), vec![0, 1, 2, 3, 4, 5]);
    let n = x.len();
    let slip = 0.3;
    let c = test_cable(path, 0.25, 0.0, 0.05, slip);
    let forces = |v: &[f64]| cable_forces_at(&c, &x, v);
    let mut rng = Rng::new(77);
    let (mut inside, mut beyond, mut checked) = (0, 0, 0);
    while checked < 3 * N_CONFIGS {
        let v = rng.vec(n, 0.5);
        let dv = rng.vec(n, 1.0);
        let (_, ev) = forces(&v);
        // (away from the kinks at the slip speed, where the derivative jumps)
        if ev.sliding_m_s.iter().any(|s| (s.abs() - slip).abs() < 1e-3) {
            continue;
        }
        checked += 1;
        inside += ev.sliding_m_s.iter().filter(|s| s.abs() < slip).count();
        beyond += ev.sliding_m_s.iter().filter(|s| s.abs() >= slip).count();
        let mut dq = vec![0.0; n];
        cable::add_friction_derivative(&c, &ev, None, &x, &dv, &mut dq);
        let eps = 1e-6;
        let vp: Vec<f64> = v.iter().zip(&dv).map(|(a, b)| a + eps * b).collect();
        let vm: Vec<f64> = v.iter().zip(&dv).map(|(a, b)| a - eps * b).collect();
        let (qp, _) = forces(&vp);
        let (qm, _) = forces(&vm);
        let fd: Vec<f64> = qp
            .iter()
            .zip(&qm)
            .map(|(a, b)| (a - b) / (2.0 * eps))
            .collect();
        let scale = fd.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for i in 0..n {
            assert!(
                (dq[i] - fd[i]).abs() <= FD_TOL * scale,
                "coordinate {i}: {} vs finite differences {} (sliding {:?})",
                dq[i],
                fd[i],
                ev.sliding_m_s
            );
        }
        if ev.sliding_m_s.iter().all(|s| s.abs() >= slip) {
            assert!(dq.iter().all(|v| *v == 0.0), "saturated: no derivative");
        }
    }
    assert!(
        inside > 0 && beyond > 0,
        "{inside} inside, {beyond} beyond the blend"
    );
}

/// The secant form of the friction derivative (the Newton steps' retry,
/// `add_friction_derivative` with the step start's sliding): where every
/// pulley is saturated at both ends, the plain derivative is 0, while the
/// secant one applied to the way back to the start, dv = v0 - v, gives the
/// force change Q(v0) - Q(v) to first order in mu theta (oracle: the forces
/// evaluated at both ends). Pulleys that kept their direction add
/// nothing; at least one pulley crosses its blend in each case.
#[test]
fn friction_secant_slope_reaches_back_to_the_step_start() {
    let (x, path) = (four_pulley_path_x(), vec![0, 1, 2, 3, 4, 5]);
    let n = x.len();
    let (slip, mu) = (1e-3, 1e-3);
    let c = test_cable(path, mu, 0.0, 0.05, slip);
    let forces = |v: &[f64]| cable_forces_at(&c, &x, v);
    let mut rng = Rng::new(91);
    let (mut checked, mut crossed) = (0, 0);
    for _ in 0..10_000 {
        if checked == N_CONFIGS {
            break;
        }
        let (v0, v) = (rng.vec(n, 0.5), rng.vec(n, 0.5));
        let ((q0, ev0), (q, ev)) = (forces(&v0), forces(&v));
        let saturated = |e: &CableEval| e.sliding_m_s.iter().all(|s| s.abs() > 2.0 * slip);
        let flips = ev0
            .sliding_m_s
            .iter()
            .zip(&ev.sliding_m_s)
            .filter(|(a, b)| a.signum() != b.signum())
            .count();
        if !(saturated(&ev0) && saturated(&ev)) || flips == 0 {
            continue;
        }
        checked += 1;
        crossed += flips;
        let dv: Vec<f64> = v0.iter().zip(&v).map(|(a, b)| a - b).collect();
        let (mut plain, mut secant) = (vec![0.0; n], vec![0.0; n]);
        cable::add_friction_derivative(&c, &ev, None, &x, &dv, &mut plain);
        cable::add_friction_derivative(&c, &ev, Some(&ev0.sliding_m_s), &x, &dv, &mut secant);
        assert!(
            plain.iter().all(|d| *d == 0.0),
            "saturated: no plain derivative"
        );
        let want: Vec<f64> = q0.iter().zip(&q).map(|(a, b)| a - b).collect();
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        // (the tensions carry e^{-z}, z = sum mu theta_k dsigma_k; linear in
        // z, the change misses by about z / 2 of itself, |z| <= 2 mu sum theta)
        let z_max = 2.0 * mu * ev.wrap_rad.iter().sum::<f64>();
        for i in 0..n {
            assert!(
                (secant[i] - want[i]).abs() <= z_max * scale,
                "coordinate {i}: {} vs {} ({flips} pulleys crossed)",
                secant[i],
                want[i]
            );
        }
    }
    assert_eq!(
        checked, N_CONFIGS,
        "too few saturated pairs with a crossing"
    );
    assert!(crossed >= N_CONFIGS);
}

#[test]
fn cable_inertia_on_the_arc_without_friction() {
    let (rho, r, theta) = (0.02, 0.04, 2.0);
    let c = test_cable(vec![0, 1, 2], 0.0, rho, r, 1e-3);
    let t = 12.0;
    for (s, s_ddot) in [(0.3, 5.0), (-0.7, -3.0), (0.0, 40.0), (1.2, 0.0)] {
        let far = cable::across_pulley(&c, t, theta, s, s_ddot);
        let expect = t - rho * r * theta * s_ddot;
        assert!(
            rel_close(far, expect, CABLE_TOL),
            "s = {s}, s'' = {s_ddot}: {far} vs {expect}"
        );
    }
}

#[test]
fn evaluate_uses_the_sliding_acceleration_of_the_far_segments() {
    // mu = 0, rho > 0: T_far = T - rho r theta s''. The sliding acceleration is
    // obtained here by differentiating the sliding speed along the trajectory
    // x(t) = x + v t + a t^2 / 2 numerically.
    let (rho, r) = (0.05, 0.03);
    let c = test_cable(vec![0, 1, 2], 0.0, rho, r, 1e-3);
    let x = vee_geometry(0.5);
    let mut rng = Rng::new(77);
    for _ in 0..N_CONFIGS {
        let v = rng.vec(9, 1.0);
        let acc = rng.vec(9, 20.0);
        let sliding_at = |tau: f64| {
            let xt: Vec<f64> = (0..9)
                .map(|i| x[i] + v[i] * tau + 0.5 * acc[i] * tau * tau)
                .collect();
            let vt: Vec<f64> = (0..9).map(|i| v[i] + acc[i] * tau).collect();
            let mut ev = CableEval::for_cable(&c);
            cable::evaluate(&c, 1.0, &xt, &vt, None, &mut ev);
            ev.sliding_m_s[0]
        };
        let h = 1e-5;
        let s_ddot = (sliding_at(h) - sliding_at(-h)) / (2.0 * h);
        let mut ev = CableEval::for_cable(&c);
        let t = 500.0;
        cable::evaluate(&c, t, &x, &v, Some(&acc), &mut ev);
        let theta = ev.wrap_rad[0];
        let expect = t - rho * r * theta * s_ddot;
        // FD truncation: the test tolerance is that of the finite-difference checks.
        assert!(
            (ev.segment_tension_n[1] - expect).abs() < FD_TOL * t,
            "{} vs {expect}",
            ev.segment_tension_n[1]
        );
        assert!(ev.segment_tension_n[1] != t, "inertia term not exercised");
    }
}

// ---------------------------------------------------------------------------
// 4. Cable forces
// ---------------------------------------------------------------------------

fn cable_setup() -> (Cable, Vec<f64>) {
    // 6 joints; the path visits 5 of them (joint 3 is not on the path).
    let x = vec![
        0.0, 0.0, 0.0, //
        1.0, 0.3, -0.2, //
        1.7, 1.2, 0.4, //
        9.0, 9.0, 9.0, //
        0.9, 2.1, 1.0, //
        -0.4, 1.5, 0.2,
    ];
    let c = test_cable(vec![0, 1, 2, 4, 5], 0.3, 0.0, 0.05, 1e-3);
    (c, x)
}

#[test]
fn cable_forces_are_internal() {
    let (c, x) = cable_setup();
    let mut rng = Rng::new(5);
    for _ in 0..N_CONFIGS {
        let v = rng.vec(x.len(), 1.0);
        let mut ev = CableEval::for_cable(&c);
        cable::evaluate(&c, 80.0, &x, &v, None, &mut ev);
        let mut q = vec![0.0; x.len()];
        cable::add_forces(&c, &ev, &x, &mut q);
        let tmax = max_abs(&ev.segment_tension_n);
        assert!(tmax > 0.0);
        for k in 0..3 {
            let sum: f64 = (0..x.len() / 3).map(|j| q[3 * j + k]).sum();
            assert!(
                sum.abs() <= CABLE_TOL * tmax,
                "net force along axis {k}: {sum}"
            );
        }
        assert_eq!(&q[9..12], &[0.0; 3], "a joint off the path gets a force");
        // The motor joint is pulled along the first segment with the motor tension.
        let d = sub3(pos(&x, 1), pos(&x, 0));
        let l = norm3(d);
        for k in 0..3 {
            assert!((q[k] - 80.0 * d[k] / l).abs() <= CABLE_TOL * 80.0);
        }
    }
}

#[test]
fn cable_forces_satisfy_the_virtual_work_identity() {
    let (c, x) = cable_setup();
    let mut rng = Rng::new(6);
    for _ in 0..N_CONFIGS {
        let v = rng.vec(x.len(), 1.0);
        let mut ev = CableEval::for_cable(&c);
        cable::evaluate(&c, 60.0, &x, &v, None, &mut ev);
        // Also exercise arbitrary tensions, not only capstan-consistent ones.
        let mut evs = vec![ev.clone()];
        let mut arb = ev.clone();
        for t in arb.segment_tension_n.iter_mut() {
            *t = 100.0 * (0.5 + 0.5 * rng.sym());
        }
        evs.push(arb);
        for ev in evs {
            let mut q = vec![0.0; x.len()];
            cable::add_forces(&c, &ev, &x, &mut q);
            let w = rng.vec(x.len(), 1.0); // virtual velocity
            let qv: f64 = q.iter().zip(&w).map(|(a, b)| a * b).sum();
            let mut power = 0.0;
            let mut scale = 0.0;
            for (j, t) in ev.segment_tension_n.iter().enumerate() {
                let dl = length_rate(&x, &w, c.path[j], c.path[j + 1]);
                power += t * (-dl);
                scale += (t * dl).abs();
            }
            assert!(
                (qv - power).abs() <= CABLE_TOL * scale.max(1e-300),
                "Q.v = {qv} vs sum T (-dl/dt) = {power}"
            );
        }
    }
}

/// A direction hint (the step-start sliding the simulator passes when its iteration
/// stalls) may only matter where the cable barely slides: elsewhere friction must
/// oppose the actual sliding, or it would do positive work.
#[test]
fn direction_hint_never_overrides_real_sliding() {
    let beta = 0.6;
    let x = vee_geometry(beta);
    let (mu, slip, t) = (0.3, 1e-3, 30.0);
    let c = test_cable(vec![0, 1, 2], mu, 0.0, 0.05, slip);
    let a = pos(&x, 2);
    let la = norm3(a);
    let wrap = PI - 2.0 * beta;
    for (speed, hint) in [
        (0.2, -0.2),
        (-0.2, 0.2),
        (5.0 * slip, -1.0),
        (0.25 * slip, -1.0),
    ] {
        // anchor moving toward the pulley at `speed`: the cable slides toward the motor
        let mut v = vec![0.0; 9];
        for k in 0..3 {
            v[6 + k] = -speed * a[k] / la;
        }
        let mut ev = CableEval::for_cable(&c);
        cable::evaluate_with_direction(&c, t, &x, &v, None, Some(&[hint]), &mut ev);
        let ratio = ev.segment_tension_n[1] / t;
        if speed.abs() >= slip {
            let expect = (-mu * wrap * speed.signum()).exp();
            assert!(
                rel_close(ratio, expect, CABLE_TOL),
                "speed {speed}, hint {hint}: ratio {ratio} vs {expect}"
            );
            // friction power (T0 - T1) * s >= 0
            assert!((t - ev.segment_tension_n[1]) * ev.sliding_m_s[0] >= 0.0);
        } else {
            // inside the blend zone the hint decides the direction
            assert!(
                rel_close(ratio, (mu * wrap).exp(), CABLE_TOL),
                "blend zone follows the hint: {ratio}"
            );
        }
    }
}

/// The frame hinge's axis is fixed in the post's body whatever the shear of the
/// frame member: the chord that satisfies it at 40 deg still does when the frame
/// member turns (about the frame's normal) to 0 or 70 deg, while `hinge_axis`
/// (whose body member must stay square) would tilt its axis; turning the chord
/// about the post breaks it.
#[test]
fn frame_hinge_axis_does_not_turn_with_the_frames_shear() {
    let f = frame_hinge_fixture();
    let el = f.build();
    let mut x = f.x0.clone();
    assert!(residual(el.as_ref(), &x)[0].abs() < 1e-15);
    for deg in [0.0f64, 20.0, 70.0] {
        let (s, c) = deg.to_radians().sin_cos();
        x[0..3].copy_from_slice(&[2.0 - 0.7 * c, 0.0, 0.7 * s]);
        let r = residual(el.as_ref(), &x)[0];
        assert!(r.abs() < 1e-14, "{deg} deg: residual {r}");
    }
    // the chord turned 5 deg about the post leaves the hinge's plane
    let (s, c) = 5f64.to_radians().sin_cos();
    let (dx, dy) = (1.9 - 2.0, 0.8);
    x[9..12].copy_from_slice(&[2.0 + c * dx - s * dy, s * dx + c * dy, 0.2]);
    assert!(residual(el.as_ref(), &x)[0].abs() > 1e-2);
}

/// The rows that skip joints (checked against finite differences above,
/// with every other element's rows): a scissor's two rods miss two joints
/// each, an angulated scissor's six distance rows three and its two planes
/// one each.
#[test]
fn scissor_rows_name_the_joints_they_miss() {
    for (f, missed) in [
        (scissor_ratio1_fixture(), 4),
        (scissor_ratio2_fixture(), 4),
        (angulated_fixture(), 20),
    ] {
        let el = f.build();
        let n = (0..rows(el.as_ref()))
            .flat_map(|r| (0..el.joints().len()).map(move |j| (r, j)))
            .filter(|&(r, j)| !el.row_touches(true, r, j))
            .count();
        assert_eq!(n, missed, "{}", f.label);
    }
}
