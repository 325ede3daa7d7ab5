"""Shared fixtures of the Python module's tests (run by ctest: tests/python/CMakeLists.txt)."""

import os
import pathlib

import pytest

import alphainv

SOURCE_DIR = pathlib.Path(os.environ.get("ALPHAINV_SOURCE_DIR", pathlib.Path(__file__).parents[2]))
BUILD_DIR = pathlib.Path(os.environ.get("ALPHAINV_BUILD_DIR", SOURCE_DIR / "build" / "release"))


def truth_alpha_model(ds):
    """The plant's alpha-model from dataset.json's `truth` (written by the C++ generator)."""
    am = ds.extra["truth"]["alpha_model"]
    return alphainv.AlphaModel(am["alpha"], am["c_n1"], am["beta_alpha"], am["beta_n1"])


@pytest.fixture(scope="session")
def one_pose():
    """One pose's 10 runs of the virtual Omni (9 sines, 1 square), no effects, seed 3."""
    return alphainv.Dataset.generate(3, pose=3, effects=alphainv.Effects())


@pytest.fixture(scope="session")
def small():
    """A small generated dataset (one pose, 2 s transients): for the batch tests."""
    return dict(pose=1, sine_settle_s=2.0, sine_steady_s=1.0, square_duration_s=4.0)
