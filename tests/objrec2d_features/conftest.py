"""Fixtures for the feature-detection tests: the real images, and a skip for feature types this OpenCV
lacks (OpenCV 5 ships AKAZE, BRISK and KAZE only in the contrib wheels)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec2d.features import unavailable_reason


@pytest.fixture(scope="session")
def images(shared_data: Path) -> Path:
    return shared_data / "images"


def read(path: Path, flags: int = cv2.IMREAD_COLOR) -> np.ndarray:
    image = cv2.imread(str(path), flags)
    assert image is not None, f"cannot read {path}"
    return image


@pytest.fixture(scope="session")
def box(images: Path) -> np.ndarray:
    return read(images / "box.png")


@pytest.fixture(scope="session")
def box_in_scene(images: Path) -> np.ndarray:
    return read(images / "box_in_scene.png")


def require(feature_type: str) -> None:
    """Skip, saying why, where the installed OpenCV cannot make this feature type."""
    reason = unavailable_reason(feature_type)
    if reason is not None:
        pytest.skip(reason)


@pytest.fixture
def require_feature():
    return require
