"""Sweeps from Python: the rows of `truss-deploy sweep` for the same file,
through a dask.distributed LocalCluster, a process pool and this process;
one row per sample whatever happened; SweepError naming the line."""

import concurrent.futures as cf
import pickle

import pyarrow.parquet as pq
import pytest

import truss_deploy as td
from conftest import MODELS, REPO


def small_mast_sweep(tmp_path, samples=4):
    """docs/sweeps/mast.toml with a few samples, its base model by absolute path."""
    text = (REPO / "docs/sweeps/mast.toml").read_text()
    text = text.replace("samples = 200", f"samples = {samples}")
    text = text.replace('"../../models/pantograph_mast.toml"', f'"{MODELS / "pantograph_mast.toml"}"')
    path = tmp_path / "mast_small.toml"
    path.write_text(text)
    return path


def comparable(table):
    return table.drop(["wall_time_s"]).to_pylist()


@pytest.fixture(scope="module")
def cli_rows(cli, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sweep")
    path = small_mast_sweep(tmp)
    cli("sweep", path, "-o", tmp / "out", "--jobs", "2")
    return path, pq.read_table(tmp / "out" / "results.parquet")


def test_a_sweep_on_a_dask_cluster_gives_the_cli_rows(cli_rows):
    distributed = pytest.importorskip("dask.distributed")
    path, want = cli_rows
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        result = td.run_sweep(path, executor=client)
    got = result.table()
    assert got.schema.equals(want.schema, check_metadata=True)
    assert comparable(got) == comparable(want)
    assert len(result) == 4 and [r["index"] for r in result.rows] == [0, 1, 2, 3]
    assert all(r["stop_reason"] == "deployed" for r in result.rows)
    df = result.to_pandas()
    assert list(df.columns) == want.column_names
    assert result.summary["samples"] == 4


def test_a_sweep_in_a_process_pool_and_in_this_process(cli_rows):
    path, want = cli_rows
    sweep = td.Sweep.load(path)
    assert len(sweep) == 4 and sweep.columns == [c for c in want.column_names if c.startswith("p_")]
    with cf.ProcessPoolExecutor(2) as pool:
        assert comparable(sweep.run(pool).table()) == comparable(want)
    assert comparable(sweep.run(jobs=2).table()) == comparable(want)
    # a sample is a picklable work item that runs anywhere the library is
    task = pickle.loads(pickle.dumps(sweep.tasks([2])[0]))
    import json

    assert json.loads(task())["index"] == 2


def test_a_sweep_described_as_a_dict():
    spec = {
        "sweep": {"name": "ring_mu", "seed": 7},
        "base": {"generator": "mast", "args": {"units": 2}},
        "param": [{"key": "generator.mu", "dist": "list", "values": [0.002, 0.01]}],
    }
    r = td.run_sweep(spec, jobs=2)
    df = r.to_pandas()
    assert list(df["p_generator_mu"]) == [0.002, 0.01]
    assert list(df["stop_reason"]) == ["deployed", "deployed"]


class _Failing:
    """An executor whose second sample's worker fails."""

    def __init__(self):
        self.pool = cf.ThreadPoolExecutor(2)

    def submit(self, task):
        if task.index == 1:
            f = cf.Future()
            f.set_exception(RuntimeError("worker lost"))
            return f
        return self.pool.submit(task)


def test_a_failed_sample_is_its_row(tmp_path):
    path = small_mast_sweep(tmp_path, samples=3)
    r = td.Sweep.load(path).run(_Failing())
    reasons = [row["stop_reason"] for row in r.rows]
    assert reasons == ["deployed", "error", "deployed"]
    assert "worker lost" in r.rows[1]["stop_message"]
    assert r.table().num_rows == 3


def test_a_bad_sweep_names_the_line_and_the_key(tmp_path):
    path = small_mast_sweep(tmp_path)
    text = path.read_text().replace("min = 0.002", "min = 0.5")
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(td.SweepError) as e:
        td.Sweep.load(bad)
    line = text.splitlines().index('key = "cable.drive.friction_mu"') + 1
    assert str(e.value).startswith(f"{bad}:{line}: [[param]] `cable.drive.friction_mu`")
    with pytest.raises(td.SweepError, match="<dict>"):
        td.Sweep.from_dict({"sweep": {"name": "x"}})
    with pytest.raises(td.SweepError, match="cannot read"):
        td.Sweep.load(tmp_path / "none.toml")
