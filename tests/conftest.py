"""Shared fixtures and the ``--runslow`` / ``--runlong`` switches.

Three tiers (README, ``.ci/run``):

* unmarked tests: the default ``pytest -q tests``, a few minutes;
* ``@pytest.mark.slow`` (validation runs of tens of seconds to minutes): run only with
  ``pytest --runslow`` or ``TERRASPH_RUN_SLOW=1``; ``.ci/run`` runs them;
* ``@pytest.mark.long`` (studies of tens of minutes, e.g. the five-leg sweep at 0.2 rad/s): run only
  with ``pytest --runlong`` or ``TERRASPH_RUN_LONG=1``, an explicit opt-in that CI does not make;
  their figures are recorded in docs/benchmarks.md with the command that produces them.

Skipped tests say how to run them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

pytest_plugins = ("pytester",)  # test_test_tiers.py runs the tier switches on a throw-away suite


@pytest.fixture(scope="session", autouse=True)
def no_mujoco_log_file():
    """MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory; terrasph
    passes MuJoCo's warnings on through Python's (terrasph.mjcf.model.mujoco_warnings), so the suite
    (gymnasium's half cheetah with its deprecated attribute, diverging robots) must leave none."""
    log = Path.cwd() / "MUJOCO_LOG.TXT"
    existed = log.exists()
    yield
    assert existed or not log.exists(), f"the tests left MuJoCo's {log}: a MuJoCo warning bypassed mujoco_warnings"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--runslow", action="store_true", default=False,
                     help="also run tests marked slow (or set TERRASPH_RUN_SLOW=1)")
    parser.addoption("--runlong", action="store_true", default=False,
                     help="also run tests marked long, studies of tens of minutes (or set TERRASPH_RUN_LONG=1)")


def _run_slow(config: pytest.Config) -> bool:
    return bool(config.getoption("--runslow")) or os.environ.get("TERRASPH_RUN_SLOW", "") == "1"


def _run_long(config: pytest.Config) -> bool:
    return bool(config.getoption("--runlong")) or os.environ.get("TERRASPH_RUN_LONG", "") == "1"


def pytest_configure(config: pytest.Config) -> None:
    # also declared in pyproject.toml; repeated so the markers are known when run from elsewhere
    config.addinivalue_line("markers", "slow: validation runs of minutes; need --runslow or TERRASPH_RUN_SLOW=1")
    config.addinivalue_line("markers", "long: studies of tens of minutes; need --runlong or TERRASPH_RUN_LONG=1")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    skip_slow = pytest.mark.skip(reason="slow validation run: use --runslow or TERRASPH_RUN_SLOW=1")
    skip_long = pytest.mark.skip(reason="long study (tens of minutes): use --runlong or TERRASPH_RUN_LONG=1")
    for item in items:
        if "long" in item.keywords and not _run_long(config):
            item.add_marker(skip_long)
        elif "slow" in item.keywords and not (_run_slow(config) or _run_long(config)):
            item.add_marker(skip_slow)


@pytest.fixture(autouse=True, scope="session")
def _a_settle_cache_of_the_session(tmp_path_factory: pytest.TempPathFactory):
    """The tests' robot runs keep their settled pauses (terrasph.settle_cache) in a directory of the
    session, never in the user's cache; the variable reaches the CLI's subprocesses too."""
    from terrasph.settle_cache import CACHE_ENV

    before = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("settle_cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = before


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator, so every random test is reproducible."""
    return np.random.default_rng(20240611)


@pytest.fixture
def restore_threads():
    """Restores the OpenMP thread count a test changed (process-wide setting), and splits every
    loop across the threads meanwhile, however few its particles (the core gives each thread at
    least ``get_particles_per_thread()`` particles otherwise, so a small test scene would run on
    one thread whatever the count)."""
    from terrasph import _core

    before, per_thread = _core.get_max_threads(), _core.get_particles_per_thread()
    _core.set_particles_per_thread(1)
    yield
    _core.set_num_threads(before)
    _core.set_particles_per_thread(per_thread)


def _free_block(spacing: float, nx: int, nz: int, *, margin: float = 0.5):
    """A wall-free, gravity-free lattice block of nx × nz particles in a roomy domain box.

    Returns (scene, block positions). The domain is padded by `margin` (m) on every side so that
    nothing in a short run can reach its edge.
    """
    from terrasph.scene import Scene

    scene = Scene(spacing=spacing)
    scene.gravity = 0.0
    block = scene.add_block(0.0, 0.0, nx * spacing, nz * spacing)
    scene.domain_lower = (-margin, -margin)
    scene.domain_upper = (nx * spacing + margin, nz * spacing + margin)
    return scene, block


def _bulk_mask(position: np.ndarray, block: np.ndarray, distance: float) -> np.ndarray:
    """Particles at least `distance` from every edge of the block's bounding box."""
    lo = block.min(axis=0)
    hi = block.max(axis=0)
    return np.all((position >= lo + distance) & (position <= hi - distance), axis=1)


@pytest.fixture
def free_block():
    """Factory ``free_block(spacing, nx, nz, margin=0.5) -> (scene, block)``: no walls, no gravity."""
    return _free_block


@pytest.fixture
def bulk_mask():
    """Function ``bulk_mask(position, block, distance)``: particles ≥ distance from the block's edges."""
    return _bulk_mask
