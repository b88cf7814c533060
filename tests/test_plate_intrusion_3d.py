"""The 3D plate intrusion on the run loop (terrasph.scenes.plate_intrusion_3d, docs/sph3d.md).

References: in dry granular media the resisting stress on a slowly intruding flat plate grows
linearly with depth, σ_z ≈ α ρ g z with α of order 10 (the sources in
terrasph.scenes.plate_intrusion); the run's F_z past the first contact grows with depth (a line fit
with R² > 0.8 [0.93], its slope positive) and α lies in the loose band 1 < α < 100 [11.3], the same
band as the planar scene's test. The run writes the output contract (run file with status, frames,
series and results; XDMF sidecars with XYZ geometry; checkpoint; PNG). The same run is bitwise the
same with 1, 2 and 3 threads, and a run stopped and resumed from its checkpoint is bitwise the
run that never stopped.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from terrasph import _core
from terrasph.config import ConfigError
from terrasph.scenes.plate_intrusion_3d import PlateIntrusion3D, run_plate_intrusion_3d

SMALL = PlateIntrusion3D(bed_length=0.08, bed_breadth=0.08, bed_depth=0.05, plate_length=0.03, plate_breadth=0.03,
                         speed=0.05, max_depth=0.012, settle_time=0.02)
SHORT = PlateIntrusion3D(bed_length=0.06, bed_breadth=0.06, bed_depth=0.04, plate_length=0.02, plate_breadth=0.02,
                         speed=0.05, max_depth=0.008, settle_time=0.0, frame_interval=0.01)


def run_file(path) -> dict[str, np.ndarray]:
    """Every dataset of the frames and series of a run file."""
    arrays: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as file:
        for group in ("frames", "series"):
            file[group].visititems(lambda name, item, g=group: arrays.__setitem__(f"{g}/{name}", item[()])
                                   if isinstance(item, h5py.Dataset) else None)
    return arrays


@pytest.mark.slow
def test_the_3d_plate_meets_a_resistance_growing_with_depth_and_writes_the_contract(tmp_path) -> None:
    out = tmp_path / "plate3d.h5"
    result = run_plate_intrusion_3d(SMALL, output=out, progress=False)
    slope, _, r_squared = result.fit()
    assert slope > 0 and r_squared > 0.8
    assert 1.0 < result.alpha() < 100.0
    assert result.leaked_particles == 0
    with h5py.File(out, "r") as file:
        assert file["run"].attrs["status"] == "completed"
        assert file["frames/position"].shape[2] == 3
        assert file["frames/stress"].shape[2:] == (3, 3)
        assert file["results"].attrs["alpha"] == pytest.approx(result.alpha())
        assert file["series/bodies/plate/orientation"].shape[1] == 4
    for suffix in (".xdmf", ".grains.xdmf", ".bodies.xdmf", ".walls.xdmf", ".png", ".checkpoint.h5"):
        assert out.with_name("plate3d" + suffix).is_file(), suffix
    geometry = ET.parse(out.with_suffix(".xdmf")).getroot().find(".//Geometry")
    assert geometry is not None and geometry.get("GeometryType") == "XYZ"


@pytest.mark.slow
def test_bitwise_with_one_two_and_three_threads(tmp_path, restore_threads) -> None:
    runs = []
    for threads in (1, 2, 3):
        _core.set_num_threads(threads)
        out = tmp_path / f"threads{threads}.h5"
        run_plate_intrusion_3d(SHORT, output=out, progress=False, plot=False, until=0.04)
        runs.append(run_file(out))
    assert np.abs(runs[0]["series/bodies/plate/force"][-1]).max() > 0  # the plate is in the grains
    for other in runs[1:]:
        for name, value in runs[0].items():
            if name != "series/diagnostics/wall_time":
                assert np.array_equal(value, other[name]), name


@pytest.mark.slow
def test_a_resumed_3d_run_is_bitwise_the_run_that_never_stopped(tmp_path) -> None:
    whole = tmp_path / "whole.h5"
    run_plate_intrusion_3d(SHORT, output=whole, progress=False, plot=False, until=0.04)
    stopped = tmp_path / "stopped.h5"
    run_plate_intrusion_3d(SHORT, output=stopped, progress=False, plot=False, until=0.02)
    run_plate_intrusion_3d(SHORT, output=stopped, progress=False, plot=False, until=0.04, resume=True)
    a, b = run_file(whole), run_file(stopped)
    assert a.keys() == b.keys()
    for name, value in a.items():
        if name != "series/diagnostics/wall_time":
            assert np.array_equal(value, b[name]), name


def test_bad_3d_plate_configurations_are_refused() -> None:
    with pytest.raises(ConfigError, match="'max_depth'"):
        PlateIntrusion3D(max_depth=0.05)
    with pytest.raises(ConfigError, match="'plate_breadth'"):
        PlateIntrusion3D(plate_breadth=0.1)
    with pytest.raises(ConfigError, match="'speed'"):
        PlateIntrusion3D(speed=-1.0)
    with pytest.raises(ConfigError, match="'mu1_deg'"):
        PlateIntrusion3D(mu1_deg=40.0)  # above mu2_deg


def test_the_bed_material_options_reach_the_3d_bed() -> None:
    """μ1 = 20°, μ2 = 30°, w = 0.5 % given to the scene: the simulation it builds has that bed (μ = tan
    of the angle, Eq. 2.31; wet densities × (1 + w)) under the configured model, and without them the
    chapter 3 beads (terrasph.scenes.leg_rotation.glass_beads, built here from its own numbers)."""
    import math

    from terrasph.scenes.plate_intrusion_3d import build_plate_intrusion_3d

    wet = build_plate_intrusion_3d(PlateIntrusion3D(**{**TINY, "mu1_deg": 20.0, "mu2_deg": 30.0,
                                                      "water_content": 0.005})).material
    assert (wet.mu1, wet.mu2) == (math.tan(math.radians(20.0)), math.tan(math.radians(30.0)))
    assert wet.reference_density == pytest.approx(2600.0 * 0.63 * 1.005) and wet.water_content == 0.005
    dry = build_plate_intrusion_3d(PlateIntrusion3D(**TINY)).material
    assert (dry.mu1, dry.reference_density, dry.model) == (math.tan(math.radians(23.0)), 2600.0 * 0.63,
                                                           "mu_i_hypoelastic")


#: the smallest bed of the checks above, to build (not run)
TINY = {"bed_length": 0.06, "bed_breadth": 0.06, "bed_depth": 0.04, "plate_length": 0.02, "plate_breadth": 0.02,
        "max_depth": 0.008}


def test_the_size_guard_estimates_the_3d_bed() -> None:
    """The guard's particles, V/Δx³ + S·layers/Δx² (terrasph.size_guard), against the bed built: within
    15 % on the default bed (12 × 12 × 6 cm at Δx = 5 mm: the box's edges and corners, which the area
    leaves out, make it [10 %] short); its steps, t_end/(cfl h/c0), against the core's own first step
    at rest: within 1 %."""
    from terrasph.scenes.plate_intrusion_3d import build_plate_intrusion_3d
    from terrasph.size_guard import estimate

    config = PlateIntrusion3D()
    sim = build_plate_intrusion_3d(config)
    sim.advance(1.0, max_steps=1)
    size = estimate(config.footprint())
    assert size.particles == pytest.approx(len(sim.core.mass) + len(sim.core.wall_position), rel=0.15)
    assert config.end_time / size.steps == pytest.approx(sim.core.last_dt, rel=0.01)
