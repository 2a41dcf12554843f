"""Shared fixtures: the repository's bundled models and the `truss-deploy`
binary the Python results are compared with (TRUSS_DEPLOY_BIN, else
target/release or target/debug under CARGO_TARGET_DIR or the repository)."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "models"
BUNDLED = ["pantograph_mast", "double_ring", "double_ring_synchronized", "sail_array"]


def _find_bin():
    env = os.environ.get("TRUSS_DEPLOY_BIN")
    if env:
        return env
    targets = [Path(os.environ["CARGO_TARGET_DIR"])] if os.environ.get("CARGO_TARGET_DIR") else []
    targets.append(REPO / "target")
    for t in targets:
        for profile in ("release", "debug"):
            p = t / profile / "truss-deploy"
            if p.exists():
                return str(p)
    return shutil.which("truss-deploy")


@pytest.fixture(scope="session")
def cli():
    """Runs the truss-deploy binary; skipped without one unless
    TRUSS_REQUIRE_CLI=1 (as CI sets it)."""
    exe = _find_bin()
    if exe is None:
        if os.environ.get("TRUSS_REQUIRE_CLI") == "1":
            pytest.fail("no truss-deploy binary: set TRUSS_DEPLOY_BIN or build it (cargo build --release)")
        pytest.skip("no truss-deploy binary (set TRUSS_DEPLOY_BIN)")

    def run(*args, check=True, cwd=None):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, cwd=cwd)
        if check and p.returncode != 0:
            raise AssertionError(f"truss-deploy {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
        return p

    return run
