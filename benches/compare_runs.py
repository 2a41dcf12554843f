#!/usr/bin/env python3
"""Compare two truss-deploy binaries on the bundled models (a refactor check).

    benches/compare_runs.py OLD_BINARY NEW_BINARY [--tol 1e-9] [models...]

Runs `simulate MODEL --json` with each binary and checks that the deploy
times and the lock tables (names in order, times) agree to --tol seconds, and
prints the largest relative difference of the impulses and energies lost.
Exit status 1 on any disagreement.
"""
import json, subprocess, sys, tempfile, os

def run(binary, model, out):
    p = subprocess.run([binary, "simulate", model, "--json", out], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{binary} simulate {model}: exit {p.returncode}\n{p.stderr}")
    with open(out) as f:
        return json.load(f)

def main():
    args = sys.argv[1:]
    tol = 1e-9
    if "--tol" in args:
        i = args.index("--tol"); tol = float(args[i + 1]); del args[i:i + 2]
    old, new, models = args[0], args[1], args[2:] or [
        "models/pantograph_mast.toml", "models/double_ring_synchronized.toml", "models/sail_array.toml"]
    bad = False
    with tempfile.TemporaryDirectory() as d:
        for m in models:
            a = run(old, m, os.path.join(d, "old.json"))
            b = run(new, m, os.path.join(d, "new.json"))
            dt = abs(a["deploy_time_s"] - b["deploy_time_s"])
            la, lb = a["locks"], b["locks"]
            names_ok = [l["name"] for l in la] == [l["name"] for l in lb]
            dlock = max((abs(x["time_s"] - y["time_s"]) for x, y in zip(la, lb)), default=0.0)
            rel = lambda k: max((abs(x[k] - y[k]) / max(abs(x[k]), 1e-300) for x, y in zip(la, lb)), default=0.0)
            ok = dt <= tol and names_ok and len(la) == len(lb) and dlock <= tol
            bad |= not ok
            print(f"{m}: deploy {a['deploy_time_s']:.12f} vs {b['deploy_time_s']:.12f} s (diff {dt:.1e}), "
                  f"{len(la)} vs {len(lb)} locks, same order {names_ok}, max lock time diff {dlock:.1e} s, "
                  f"max rel diff impulse {rel('impulse_ns'):.1e}, energy {rel('energy_lost_j'):.1e}, "
                  f"steps {a['steps']} vs {b['steps']}: {'OK' if ok else 'DIFFERENT'}")
    sys.exit(1 if bad else 0)

main()
