"""Shared helpers of the Python package's tests: the repository's scenes and the `lancer` CLI."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
SCENES = ROOT / "scenes"


def cli():
    """The `lancer` binary the Python renders are compared with: $LANCER_CLI, or the release build."""
    path = os.environ.get("LANCER_CLI") or str(ROOT / "target" / "release" / "lancer")
    if os.environ.get("LANCER_CLI") and not os.path.exists(path):
        pytest.fail(f"LANCER_CLI names no file: {path}")
    if not os.path.exists(path):
        pytest.skip(f"no lancer binary at {path}: build it (cargo build --release) or set LANCER_CLI")
    return path


def run_cli(*args):
    return subprocess.run([cli(), *map(str, args)], check=True, capture_output=True, text=True)
