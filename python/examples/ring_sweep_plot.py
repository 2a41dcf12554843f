"""A ring sweep from Python: synchronized 12-sided double rings (elastic members:
rigid ones meet the flat state's near-singularity, where a run stops at its first
inexact result) whose drive tension, pulley friction and joint damping scatter, run on every core (or a
Dask cluster), and the distribution of their deploy times plotted with
matplotlib (Agg backend) to a PNG.

    python python/examples/ring_sweep_plot.py [--samples 24] [--dask] [-o ring_deploy_times.png]
"""

import argparse
import concurrent.futures as cf
import os

import truss_deploy as td


def sweep_spec(samples: int) -> dict:
    """The sweep, as the dict of a sweep file's tables (docs/sweeps.md)."""
    return {
        "sweep": {"name": "ring12_sync_mc", "seed": 49, "samples": samples, "max_wall_s": 120.0},
        "base": {"generator": "ring", "args": {"sides": 12, "sync": "both", "tension_n": 15.0, "damping": 50.0,
                                                   "members": "elastic"}},
        "param": [
            {"key": "generator.tension_n", "dist": "uniform", "min": 0.8, "max": 1.2, "relative": True},
            {"key": "generator.mu", "dist": "uniform", "min": 0.002, "max": 0.03},
            {"key": "generator.damping", "dist": "uniform", "min": 0.8, "max": 1.2, "relative": True},
        ],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--dask", action="store_true", help="run on a local dask.distributed cluster")
    ap.add_argument("-o", "--output", default="ring_deploy_times.png")
    args = ap.parse_args()

    sweep = td.Sweep.from_dict(sweep_spec(args.samples))
    workers = os.cpu_count() or 1
    if args.dask:
        from dask.distributed import Client, LocalCluster

        with LocalCluster(n_workers=workers, processes=True, threads_per_worker=1,
                          host="127.0.0.1", dashboard_address=None) as cluster, Client(cluster) as client:
            result = sweep.run(client)
    else:
        with cf.ProcessPoolExecutor(workers) as pool:
            result = sweep.run(pool)
    df = result.to_pandas()
    deployed = df[df["deployed"]]
    print(f"{len(df)} samples, {len(deployed)} deployed; deploy time "
          f"min {deployed['deploy_time_s'].min():.2f} s, median {deployed['deploy_time_s'].median():.2f} s, "
          f"max {deployed['deploy_time_s'].max():.2f} s")
    corr = df[["p_generator_tension_n", "p_generator_mu", "p_generator_damping", "deploy_time_s"]].corr(method="spearman")
    print("rank correlation with the deploy time:", corr["deploy_time_s"].drop("deploy_time_s").round(2).to_dict())

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.5))
    a.hist(deployed["deploy_time_s"], bins=max(5, len(deployed) // 3), color="tab:blue")
    a.set_xlabel("deploy time (s)")
    a.set_ylabel("samples")
    a.set_title(f"{len(deployed)} of {len(df)} rings deployed")
    b.scatter(deployed["p_generator_mu"], deployed["deploy_time_s"], c=deployed["p_generator_tension_n"], cmap="viridis")
    b.set_xlabel("pulley friction mu")
    b.set_ylabel("deploy time (s)")
    b.set_title("colour: tension factor")
    fig.tight_layout()
    fig.savefig(args.output, dpi=100)
    print(f"wrote {args.output}")
    assert len(deployed) == len(df), "a ring did not deploy"


if __name__ == "__main__":
    main()
