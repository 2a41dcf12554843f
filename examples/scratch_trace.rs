use truss_deploy::solver::{Options, Simulator};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let m = truss_deploy::model::load(std::path::Path::new(&args[1]))
        .unwrap()
        .model;
    let t0: f64 = args[2].parse().unwrap();
    let t1: f64 = args[3].parse().unwrap();
    let mut sim = Simulator::new(m, Options::default()).unwrap();
    while sim.state().t_s < t0 - 1e-9 {
        sim.step(0.05).unwrap();
    }
    std::env::set_var("TD_TRACE", "1");
    while sim.state().t_s < t1 - 1e-9 {
        if let Err(e) = sim.step(0.05) {
            eprintln!("err {e}");
            break;
        }
    }
    eprintln!("{}", sim.solver_stats().line());
}
