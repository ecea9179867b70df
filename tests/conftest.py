"""Shared fixtures: small simulated clips and paths to ../shared/data."""

from pathlib import Path

import numpy as np
import pytest
from skimage import data

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session")
def scene() -> np.ndarray:
    """A textured RGB photo shipped with scikit-image."""
    return data.astronaut()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared data folder {SHARED} is absent (it lives beside the repository)")
    return SHARED
