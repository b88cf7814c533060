"""Extreme cases end as a finished run or are refused with a reason before any work; "unstable" is
kept for numerical failures. The sweep of the issue: a leg turned at up to 30 rad/s, a wheel under
up to 60 N, μ1 down to 5°, tall and wide columns, the pendular limit of the water content, shallow
beds. Each at the coarsest resolution and a short end time: ~25 s of CPU in the fast tier, the
30 rad/s leg ~20 s in the slow one.

Physical references: grains flung by a part moving at v rise about v²/2g (ballistic), so the
container's walls sized from that keep them (terrasph.scene.flung_height, measured: 0.255 m above
the bed at 30 rad/s against v²/2g = 0.266 m); a column's runout follows the quasi-2D scaling of
Lube et al. (2005), so a floor sized from it holds the deposit (the 0.5 m column ran 1.35 times the
fit at the coarse resolution)."""

from __future__ import annotations

import warnings

import pytest
from terrasph.config import ConfigError
from terrasph.run_loop import FINISHED_STATUSES
from terrasph.scenes.column_collapse import ColumnCollapse, run_column_collapse
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

#: the README's coarse leg-wheel (Δx = 5 mm, legs 1.5 cm thick and 5 cm long, a 30 × 5 cm bed)
README_WHEEL = dict(wheel="reversed-c-leg", spacing=0.005, thickness=0.015, leg_length=0.05, bed_width=0.3,
                    bed_depth=0.05, start_x=0.1, settle_time=0.1, t_end=0.4)




@pytest.mark.parametrize("changes", [
    {"column_height": 0.5},                          # a = 7.1: ran past the former 35 cm floor
    {"column_width": 0.3, "column_height": 0.02},    # a = 0.07
    {"friction_angles_deg": (5.0, 33.0), "t_end": 0.6},
    {"water_content": 0.0263},                       # the pendular limit (liquid saturation 0.1)
], ids=["tall", "wide", "mu1-5deg", "pendular-limit"])
def test_extreme_columns_finish(changes: dict) -> None:
    config = ColumnCollapse(resolution="coarse", **changes)
    result = run_column_collapse(config, output=None, progress=False, plot=False)
    assert result.run.status in FINISHED_STATUSES
    assert result.run.diagnostics["leaked_particles"][-1] == 0
    assert result.toe_front < config.floor  # the floor, sized from the runout scaling, held the deposit


def test_water_beyond_the_pendular_limit_and_a_short_floor_are_said_before_any_work() -> None:
    with pytest.raises(ConfigError, match="water_content"):
        ColumnCollapse(water_content=0.03)
    with pytest.warns(RuntimeWarning, match="floor_length"):
        ColumnCollapse(column_height=0.5, floor_length=0.35)


@pytest.mark.slow
def test_a_leg_turned_at_30_rad_per_s_keeps_its_flung_grains() -> None:
    """The coarse C-leg's sweep at 30 rad/s after a short pause, and 0.45 s for the grains it flings
    to land: they stay in the container (grains thrown over its wall ended the run as unstable)."""
    config = LegRotation(leg="c-leg", omega=30.0, resolution="coarse", settle_time=0.05, t_end=0.5)
    result = run_leg_rotation(config, output=None, progress=False, plot=False)
    assert result.run.status in FINISHED_STATUSES
    assert result.leaked_particles == 0


def test_a_leg_in_too_shallow_a_bed_is_refused_before_any_work() -> None:
    with pytest.raises(ConfigError, match="bed_depth"):
        run_leg_rotation(LegRotation(resolution="coarse", bed_depth=0.03, settle_time=0.0, t_end=0.01),
                         output=None, progress=False, plot=False)


@pytest.mark.parametrize("changes", [
    {"load": 60.0},
    {"omega": 30.0},
    {"mu1_deg": 5.0},
    {"bed_depth": 0.02},
], ids=["60N", "30rad-per-s", "mu1-5deg", "shallow-bed"])
def test_extreme_wheels_finish(changes: dict) -> None:
    """The README's coarse wheel under each extreme; a leak (the 60 N load presses a grain into a
    leg) is warned of and counted, the run goes on."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = run_leg_wheel(LegWheel(**{**README_WHEEL, **changes}), plot=False)
    leaked = run.summary()["leaked_particles"]
    assert len(run.series["robot/wheel"]["time"]) > 1
    assert run.series["robot/wheel"]["time"][-1] >= README_WHEEL["t_end"] - 0.01
    said = [w for w in caught if "leak" in str(w.message)]
    assert (leaked > 0) == bool(said)
