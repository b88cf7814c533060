"""Stiff and extreme cases (docs/design.md §3.7): stiffer materials, a too-large fixed step, a tall
column, an injected NaN, and the output file of a run that went unstable.

References and tolerances
-------------------------
* Adaptive step dt = C·min(h/(c + |v|max), √(h/|a|max)); c is the fastest signal speed and scales
  as √κ, so κ × 10 and κ × 100 must shrink the step by 1/√10 and 1/10. Measured mean steps over a
  10 ms collapse: ratios 0.3162 and 0.1000; tolerance ±10 % (the |v|max and |a| terms may shift it).
* A fixed dt 10× the stable bound is refused at the first step with an InstabilityError naming
  ``fixed_dt``; half the bound runs.
* A column with H0/L0 = 10 (1 cm × 10 cm, Δx = 2.5 mm, 160 particles) collapses for 0.2 s without
  blow-up: all particles stay finite and inside the domain, the top falls below 0.5 H0 (measured
  0.31 H0), the front advances beyond 5 L0 (measured 10 L0).
* A NaN written into a velocity or density is caught when advance() starts, at its own particle,
  with step and time set; a run that goes unstable with output leaves a readable file whose /run
  status is "unstable".
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import terrasph
from terrasph import _core
from terrasph.io import read_run
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation

SMALL = dict(column_width=0.04, column_height=0.04, spacing=0.005, floor_length=0.12)


def small_collapse(stiffness_factor: float = 1.0, **numerics) -> Simulation:
    """A 4 cm × 4 cm column (64 particles) with its gate removed at t = 0."""
    scene, material, numerics_obj = build_column_collapse(ColumnCollapse(**SMALL, numerics=numerics))
    material = dataclasses.replace(material, bulk_stiffness=material.bulk_stiffness * stiffness_factor)
    return Simulation(scene, material, numerics_obj)


def test_instability_error_is_exported() -> None:
    assert terrasph.InstabilityError is _core.InstabilityError
    assert issubclass(terrasph.InstabilityError, RuntimeError)


def test_stiffer_material_runs_stably_with_smaller_step() -> None:
    t_end = 0.01
    mean_dt = {}
    for factor in (1.0, 10.0, 100.0):
        sim = small_collapse(factor)
        sim.advance(t_end)  # raises InstabilityError on a blow-up
        assert sim.time == pytest.approx(t_end)
        assert np.all(np.isfinite(sim.position)) and np.all(np.isfinite(sim.velocity))
        rho_ratio = sim.density / sim.material.reference_density
        assert rho_ratio.min() > 0.9 and rho_ratio.max() < 1.1
        # the column did start to move (the gate is gone): several mm/s even for κ × 100
        assert sim.core.max_speed > 2e-3
        mean_dt[factor] = sim.time / sim.step_count
    for factor in (10.0, 100.0):
        assert mean_dt[factor] / mean_dt[1.0] == pytest.approx(1.0 / math.sqrt(factor), rel=0.1)


def test_fixed_dt_above_the_stable_bound_is_stopped() -> None:
    bound = small_collapse().core.stable_time_step()
    sim = small_collapse(fixed_dt=10.0 * bound)
    with pytest.raises(terrasph.InstabilityError, match="fixed_dt") as caught:
        sim.advance(0.01)
    assert caught.value.step == 0 and caught.value.time == 0.0  # refused before any work
    assert sim.step_count == 0

    ok = small_collapse(fixed_dt=0.5 * bound)
    ok.advance(100 * 0.5 * bound)
    assert ok.step_count == 100  # every step at the fixed size (no shortening before the end)


def test_tall_column_collapses_without_blow_up() -> None:
    config = ColumnCollapse(column_width=0.01, column_height=0.1, spacing=0.0025, floor_length=0.3)
    scene, material, numerics = build_column_collapse(config)
    sim = Simulation(scene, material, numerics)
    assert len(sim.mass) == 160
    lower, upper = scene.domain()
    sim.advance(0.2)
    x = sim.position
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(sim.velocity)) and np.all(np.isfinite(sim.density))
    assert np.all((x >= lower) & (x <= upper))
    assert x[:, 1].min() > 0.0  # above the floor line
    assert x[:, 1].max() < 0.5 * config.column_height
    assert x[:, 0].max() > 5 * config.column_width


def _nan_case(field: str = "velocity", refresh: bool = False) -> tuple[Simulation, int]:
    sim = small_collapse()
    sim.advance(1.0, max_steps=10)
    injected = 27  # an interior particle of the 8 × 8 column, not index 0
    if field == "velocity":
        velocity = sim.velocity.copy()
        velocity[injected, 0] = np.nan
        sim.velocity = velocity
    else:
        density = sim.density.copy()
        density[injected] = np.nan
        sim.density = density
    if refresh:  # the rates are re-evaluated: the NaN reaches the neighbours' accelerations
        sim.refresh()
    return sim, injected


@pytest.mark.parametrize("field, refresh", [("velocity", False), ("velocity", True), ("density", False)])
def test_injected_nan_is_caught_with_step_time_and_particle(field, refresh) -> None:
    """The state is checked when advance() starts, so a NaN written into the state is reported at
    its own particle, before it spreads, with the step count and time at which it was found."""
    sim, injected = _nan_case(field, refresh)
    time_before = sim.time
    with pytest.raises(terrasph.InstabilityError, match="non-finite") as caught:
        sim.advance(1.0, max_steps=10)
    error = caught.value
    assert error.particle == injected
    assert error.step == 10 and error.time == time_before  # found before another step was taken
    assert "non-finite" in error.reason
    assert f"particle id {injected}" in str(error)


def test_nan_arising_during_a_step_is_caught_at_that_step() -> None:
    """A NaN that appears inside a step (here: a NaN mass, which only enters the rates) stops the
    run at the end of that step, with the step counted and a particle index in range."""
    sim = small_collapse()
    sim.advance(1.0, max_steps=5)
    mass = sim.mass.copy()
    mass[27] = np.nan
    sim.set_field("mass", mass)
    with pytest.raises(terrasph.InstabilityError, match="non-finite") as caught:
        sim.advance(1.0, max_steps=10)
    assert caught.value.step in (5, 6)
    assert 0 <= caught.value.particle < len(sim.mass)


def test_unstable_run_leaves_a_readable_file(tmp_path) -> None:
    sim, _ = _nan_case()
    path = tmp_path / "unstable.h5"
    with pytest.raises(terrasph.InstabilityError):
        sim.run(1.0, output=path, progress=False, frame_interval=1e-3)
    run = read_run(path)
    attrs = run.group_attrs["/run"]
    assert attrs["status"] == "unstable"
    assert "non-finite" in attrs["message"]
    assert attrs["step"] == 10 and attrs["particle"] == 27
    assert run.n_frames >= 1  # the frame written at the start of the run
    assert run.frame(0)["position"].shape == (len(sim.mass), 2)
