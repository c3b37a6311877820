"""Shared fixtures: the repository, the build (TENSEGRITY_BUILD_DIR, default
build/) whose python/ folder is imported first, and the command-line program."""
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("TENSEGRITY_BUILD_DIR", ROOT / "build")).resolve()
if (BUILD / "python" / "tensegrity").is_dir():
    sys.path.insert(0, str(BUILD / "python"))


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def cli():
    program = BUILD / "tensegrity"
    if not program.exists():
        pytest.fail(f"the program {program} is not built (cmake --build {BUILD} --target tensegrity)")
    return str(program)


@pytest.fixture(scope="session")
def reference(root):
    return root / "data" / "reference"
