//! `truss-deploy`: command-line front end. See `truss-deploy --help`.
fn main() {
    std::process::exit(truss_deploy::cli::main());
}
