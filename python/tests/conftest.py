"""Shared fixtures: the real data folder and the `ratfit` CLI, found as the
Rust tests find them (RATFIT_DATA, else ../../shared/data; RATFIT_BIN, else
the workspace's release build)."""

import os
import pathlib

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent


def _found(variable, default):
    """The path a variable names (which must exist: a named path that is
    missing fails, so CI never skips), else the default when it exists."""
    named = os.environ.get(variable)
    if named:
        if not pathlib.Path(named).exists():
            pytest.fail(f"{variable}={named} does not exist")
        return pathlib.Path(named)
    return default if default.exists() else None


@pytest.fixture(scope="session")
def data_dir():
    d = _found("RATFIT_DATA", REPO.parent / "shared" / "data")
    if d is None:
        pytest.skip("no data directory (set RATFIT_DATA)")
    return d


@pytest.fixture(scope="session")
def cli():
    exe = _found("RATFIT_BIN", REPO / "target" / "release" / "ratfit")
    if exe is None:
        pytest.skip("no ratfit CLI (cargo build --release -p ratfit-cli, or set RATFIT_BIN)")
    return str(exe)
