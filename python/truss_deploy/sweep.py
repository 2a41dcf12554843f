"""Sweeps from Python: a sweep file, or a dict with the sweep file's tables
and keys (docs/sweeps.md), run on this machine's cores, on any
``concurrent.futures`` executor or on a ``dask.distributed`` cluster, with
one row per sample whatever happened; the rows as the sweep's Parquet table
(pyarrow) or a pandas DataFrame, the columns of ``truss-deploy sweep``'s
``results.parquet``.

A sample is a :class:`SampleTask`: the sweep's text, its file name and
directory, and the sample's index; it pickles, and the process that runs it
parses the sweep (once per process) and runs the sample with the library,
exactly as ``truss-deploy sweep`` does. The base model's path must be
readable where the workers run.
"""

import io
import json
import os
from dataclasses import dataclass
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

from . import _native

__all__ = ["Sweep", "SweepResult", "SampleTask", "run_sweep"]


@dataclass(frozen=True)
class SampleTask:
    """One sample of a sweep as a picklable work item; calling it runs the
    sample and returns its row as JSON text (an error or a panic in the
    sample is its row)."""

    text: str
    file: str
    dir: str
    index: int
    max_wall_s: Optional[float] = None

    def __call__(self) -> str:
        return _native._sweep_run_sample(self.text, self.file, self.dir, self.index, self.max_wall_s)


class SweepResult:
    """The rows of a sweep, in sample order.

    ``rows``: one dict per sample (the columns below, ``params`` the drawn
    values in the order of ``columns``, ``latches`` a list of dicts).
    ``parquet``: the bytes of the sweep's ``results.parquet``. ``summary``:
    the sweep's ``summary.json`` (deploy probability, quantiles, the
    parameter that drives the scatter most).
    """

    def __init__(self, sweep: "Sweep", rows: List[str]):
        self.sweep = sweep
        self.parquet, summary = _native._sweep_table(sweep.text, sweep.file, sweep.dir, rows)
        self.summary: Dict[str, Any] = json.loads(summary)
        self.rows: List[Dict[str, Any]] = sorted((json.loads(r) for r in rows), key=lambda r: r["index"])

    def __len__(self) -> int:
        return len(self.rows)

    def table(self):
        """The rows as a pyarrow Table: the columns and metadata of
        ``truss-deploy sweep``'s ``results.parquet``."""
        import pyarrow.parquet as pq

        return pq.read_table(io.BytesIO(self.parquet))

    def to_pandas(self):
        """The rows as a pandas DataFrame (the Parquet table's columns)."""
        return self.table().to_pandas()

    def write_parquet(self, path: Union[str, os.PathLike]) -> None:
        """Writes the rows as the sweep's ``results.parquet`` file."""
        with open(path, "wb") as f:
            f.write(self.parquet)


class Sweep:
    """A sweep: a base model, distributions of parameters, a seed (the
    sweep file's format, docs/sweeps.md). Checked when made: a bad key, range
    or distribution raises SweepError naming the file, the line and the key."""

    def __init__(self, text: str, file: str = "<string>", dir: Optional[str] = None):
        self.text = text
        self.file = str(file)
        self.dir = os.path.abspath(dir if dir is not None else os.getcwd())
        info = _native._sweep_info(self.text, self.file, self.dir)
        self.name: str = info["name"]
        self.sweep_id: str = info["sweep_id"]
        self.samples: int = info["samples"]
        self.keys: List[str] = info["keys"]
        self.columns: List[str] = info["columns"]
        self.seed: int = info["seed"]
        self.max_wall_s: Optional[float] = info["max_wall_s"]

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "Sweep":
        """Reads a sweep file (its base model's path is relative to it)."""
        path = os.fspath(path)
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise _native.SweepError(f"{path}: cannot read the sweep file ({e})") from None
        return cls(text, path, os.path.dirname(path) or ".")

    @classmethod
    def from_dict(cls, spec: Dict[str, Any], base_dir: Union[str, os.PathLike, None] = None) -> "Sweep":
        """A sweep described as a dict with the sweep file's tables and keys:
        ``{"sweep": {"name": ..., "seed": ..., "samples": ...}, "base":
        {"model": PATH} or {"generator": "ring", "args": {...}}, "param":
        [{"key": ..., "dist": ..., ...}, ...]}``; ``base_dir`` resolves the
        base model's path (default: the current directory)."""
        if not isinstance(spec, dict):
            raise TypeError("Sweep.from_dict: give a dict with the sweep file's tables")
        try:
            text = json.dumps(spec, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"Sweep.from_dict: {e}; give numbers, strings, booleans, lists and dicts") from None
        return cls(_native._sweep_toml_from_json(text), "<dict>", os.fspath(base_dir) if base_dir is not None else None)

    def __len__(self) -> int:
        return self.samples

    def __repr__(self) -> str:
        return f"<truss_deploy.Sweep `{self.name}`: {self.samples} samples, parameters {self.keys}>"

    def tasks(self, indices: Optional[Iterable[int]] = None, max_wall_s: Optional[float] = None) -> List[SampleTask]:
        """The samples as picklable work items (all, or those of ``indices``);
        ``max_wall_s`` over the sweep file's limit per sample (s)."""
        idx = range(self.samples) if indices is None else [int(i) for i in indices]
        for i in idx:
            if not 0 <= i < self.samples:
                raise IndexError(f"sample {i}: the sweep has {self.samples} samples")
        return [SampleTask(self.text, self.file, self.dir, i, max_wall_s) for i in idx]

    def run(
        self,
        executor: Any = None,
        *,
        jobs: Optional[int] = None,
        max_wall_s: Optional[float] = None,
        indices: Optional[Sequence[int]] = None,
    ) -> SweepResult:
        """Runs the samples (all, or ``indices``) and returns their rows.

        ``executor``: None runs them in this process on ``jobs`` threads
        (default every core), as ``truss-deploy sweep`` does; a
        ``concurrent.futures`` executor (``ProcessPoolExecutor``,
        ``ThreadPoolExecutor``) or a ``dask.distributed.Client`` runs each
        sample as a :class:`SampleTask` on its workers. A sample whose worker
        fails (an exception, a lost process) is a row with stop_reason
        "error" and the failure's message.
        """
        if max_wall_s is not None and not (max_wall_s > 0):
            raise ValueError(f"max_wall_s = {max_wall_s}: give a positive number of seconds")
        tasks = self.tasks(indices, max_wall_s)
        if executor is None:
            if jobs is not None and jobs < 1:
                raise ValueError(f"jobs = {jobs}: give at least 1 worker")
            n = jobs or os.cpu_count() or 1
            rows = _native._sweep_run_local(self.text, self.file, self.dir, [t.index for t in tasks], n, max_wall_s)
            return SweepResult(self, rows)
        if not hasattr(executor, "submit"):
            raise TypeError("executor: give a concurrent.futures executor or a dask.distributed Client")
        is_dask = hasattr(executor, "gather") and hasattr(executor, "scheduler_info")
        if is_dask:
            futures = [executor.submit(t, pure=False) for t in tasks]
        else:
            futures = [executor.submit(t) for t in tasks]
        rows = []
        for t, f in zip(tasks, futures):
            try:
                rows.append(f.result())
            except Exception as e:  # a failed worker: the sample's row says so
                msg = f"sample {t.index}: its worker failed: {type(e).__name__}: {e}"
                rows.append(_native._sweep_failed_row(self.text, self.file, self.dir, t.index, "error", msg))
        return SweepResult(self, rows)


def run_sweep(
    sweep: Union[Sweep, str, os.PathLike, Dict[str, Any]],
    executor: Any = None,
    *,
    jobs: Optional[int] = None,
    max_wall_s: Optional[float] = None,
    base_dir: Union[str, os.PathLike, None] = None,
) -> SweepResult:
    """Runs a sweep (a :class:`Sweep`, a sweep file's path, or a dict with the
    sweep file's keys) and returns its rows; see :meth:`Sweep.run`."""
    if isinstance(sweep, dict):
        sweep = Sweep.from_dict(sweep, base_dir)
    elif not isinstance(sweep, Sweep):
        sweep = Sweep.load(sweep)
    return sweep.run(executor, jobs=jobs, max_wall_s=max_wall_s)
