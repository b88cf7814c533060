"""Column runout against Lube et al. (2005) and the thin toe coming to rest. Slow.

Runout: columns of aspect ratio a = 0.5, 2 and 6 (the ends and the middle of the range 0.5–6)
with the area of the dissertation's 7 × 8 cm column at the "fit" resolution (~1040 grains,
Δx = 2.32 mm), the default beads (the packing's density, μ1 = tan 21°, μ2 = tan 33°), Coulomb wall
friction μ_w = μ1 and the default numerics (benchmarks/validation/column_runout_lube.py). L* at the deposit
front (four grain diameters thick) must lie within ±25 % of the quasi-2D fits of Lube, Huppert,
Sparks & Freundt (2005, Phys. Rev. E 72, 041301): 1.2a for a ≤ 1.8, 1.9a^(2/3) for a ≥ 2.8, linear
in between [measured ratios 0.86 / 0.98 / 1.00 with the connected deposit's front; with the
former first-drop front 0.86 / 0.98 / 0.96; docs/chapter2.md]. And each ratio within ±0.08 of its
measured value: the runs are bitwise the same at 1, 2 and 3 threads, and over the coarse, fit
and fine levels the ratios at a = 6 with μ_w = μ1 were 1.04 / 1.00 / 0.97 (at a = 4 0.99 / 0.90 /
0.97, benchmarks/validation/column_runout_lube.py), so a change of the numerics alone moves them by
less than ±0.05, while a 10 % change of the runout moves them by 0.086–0.10.

Toe: the 7 × 8 cm column at the fit level, with and without wall friction: the five front-most
grains (the one-particle toe and any grain ahead of it) move slower than 1 cm/s at t = 0.6 s
[0.05 mm/s without friction, 0.7 mm/s with it] and by less than Δx/2 = 1.16 mm between 0.6 and
1.0 s [0.013 mm, 0.13 mm]:
the toe comes to rest, it does not slide on.

About 25 s of CPU in all.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse, run_column_collapse
from terrasph.simulation import Simulation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "validation"))
from column_runout_lube import column, lube_fit

pytestmark = pytest.mark.slow

WALL_FRICTION = 0.384  #: μ_w = μ1 = tan 21°
NUMERICS = {"wall_friction_coefficient": WALL_FRICTION}


def test_lube_fit_branches() -> None:
    assert lube_fit(1.0) == pytest.approx(1.2)
    assert lube_fit(6.0) == pytest.approx(1.9 * 6.0 ** (2 / 3))
    assert lube_fit(1.8) < lube_fit(2.0) < lube_fit(2.8)


#: L*/L*_Lube measured at the fit level with μ_w = μ1 (benchmarks/validation/column_runout_lube.py)
MEASURED_RATIO = {0.5: 0.86, 2.0: 0.98, 6.0: 1.00}


@pytest.mark.parametrize("aspect", [0.5, 2.0, 6.0])
def test_runout_within_a_quarter_of_the_lube_fit(aspect: float) -> None:
    config = column(aspect, "fit", NUMERICS, t_end=3.0)
    assert config.column_height / config.column_width == pytest.approx(aspect)
    result = run_column_collapse(config, output=None, progress=False, plot=False)
    assert result.run.status == "at_rest"
    assert 0.75 <= result.runout_normalised / lube_fit(aspect) <= 1.25
    assert result.runout_normalised / lube_fit(aspect) == pytest.approx(MEASURED_RATIO[aspect], abs=0.08)
    assert result.run.diagnostics["leaked_particles"][-1] == 0


@pytest.mark.parametrize("wall_friction", [0.0, WALL_FRICTION])
def test_the_thin_toe_comes_to_rest(wall_friction: float) -> None:
    config = ColumnCollapse(resolution="fit", numerics={"wall_friction_coefficient": wall_friction})
    scene, material, numerics = build_column_collapse(config)
    sim = Simulation(scene, material, numerics)
    sim.advance(0.6)
    lead = np.argsort(sim.position[:, 0])[-5:]  # storage order is id order in the copies handed out
    x_then = sim.position[lead, 0]
    assert np.abs(sim.velocity[lead, 0]).max() < 0.01
    sim.advance(1.0)
    assert np.abs(sim.position[lead, 0] - x_then).max() < 0.5 * scene.spacing
    assert sim.leaked_particles == 0
