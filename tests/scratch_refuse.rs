use truss_deploy::model::file::parse;
use truss_deploy::solver::{Options, Simulator};
#[test]
fn scratch() {
    let src = std::fs::read_to_string("tests/compliant_elements.rs").unwrap();
    let _ = src;
    let (m, k, c, z0, g0, r) = (0.25, 100.0, 20.0, 0.01, 5e-5, 1e-4);
    let held = |name: &str, x: f64, z: f64| {
        format!("[[joint]]\nname = \"{name}\"\nposition_m = [{x}, 0.0, {z}]\nmass_kg = 1.0\n[[element]]\ntype = \"support\"\nname = \"{name}_held\"\njoints = [\"{name}\"]\nfix = \"xyz\"\n")
    };
    for mv in [1e-3, 1e-6] {
        let text = format!(
        "[model]\nname = \"g\"\n[solver]\nlatch_capture_max_move_m = {mv}\n{}{}{}{}\
         [[joint]]\nname = \"A\"\nposition_m = [0.5, 0.3, {z0}]\nmass_kg = {m}\n\
         [[element]]\ntype = \"support\"\nname = \"A_xy\"\njoints = [\"A\"]\nfix = \"xy\"\n\
         [[element]]\ntype = \"sync_hinge\"\nname = \"G\"\njoints = [\"P\", \"Q\", \"R\", \"A\", \"B\"]\n\
         mirror = \"axial\"\nstiffness_n_per_m = {k}\ndamping_n_s_per_m = {c}\n\
         [[joint]]\nname = \"C\"\nposition_m = [0.5, 0.3, -1.0]\nmass_kg = 1.0\n\
         [[element]]\ntype = \"support\"\nname = \"C_held\"\njoints = [\"C\"]\nfix = \"xyz\"\n\
         [[element]]\ntype = \"sleeve\"\nname = \"S\"\njoints = [\"C\", \"A\"]\n\
         lock_length_m = {}\ncapture_range_m = {r}\n",
        held("P", 0.0, 0.0), held("Q", 0.0, 1.0), held("R", 1.0, 0.0), held("B", 0.5, 0.0), 1.0 - g0);
        let model = parse(&text, "creep.toml").unwrap().model;
        let mut sim = Simulator::new(model, Options::default()).unwrap();
        for _ in 0..300 {
            sim.step(0.01).unwrap();
        }
        let s = sim.state();
        println!(
            "move {mv}: locks {} refused {} balance {:e} energy {:?}",
            s.locks.len(),
            sim.solver_stats().fallbacks.latch_range_refused,
            s.energy.balance_rel_error(s.kinetic_energy_j(sim.model())),
            s.energy
        );
    }
}
