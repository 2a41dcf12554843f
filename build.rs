//! Names the git commit the binary is built from, for `truss-deploy --version`:
//! `git rev-parse --short HEAD` of this package's own checkout, "unknown"
//! without git or outside one (a crate tarball). Rebuilt when HEAD moves.

use std::path::Path;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let o = Command::new("git").args(args).output().ok()?;
    let s = String::from_utf8(o.stdout).ok()?.trim().to_string();
    (o.status.success() && !s.is_empty()).then_some(s)
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default();
    // (only this package's checkout: not a repository the sources sit inside)
    let own = git(&["rev-parse", "--show-toplevel"]).is_some_and(|top| {
        let canon = |p: &str| Path::new(p).canonicalize().ok();
        canon(&top).is_some() && canon(&top) == canon(&manifest)
    });
    let commit = own
        .then(|| git(&["rev-parse", "--short", "HEAD"]))
        .flatten()
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=TRUSS_DEPLOY_COMMIT={commit}");
    if !own {
        return;
    }
    // HEAD (a checkout of another branch), the branch's ref (a commit) and
    // packed-refs (a ref packed by gc); --git-path resolves them in a worktree too.
    let mut paths = vec![git(&["rev-parse", "--git-path", "HEAD"])];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        let loose = git(&["rev-parse", "--git-path", &branch]);
        // (a branch only in packed-refs: the loose file a commit creates
        // appears in its directory)
        paths.push(match loose {
            Some(l) if !Path::new(&l).exists() => {
                Path::new(&l).parent().map(|d| d.display().to_string())
            }
            other => other,
        });
    }
    paths.push(git(&["rev-parse", "--git-path", "packed-refs"]));
    for p in paths.into_iter().flatten() {
        if Path::new(&p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
}
