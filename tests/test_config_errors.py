"""Bad input is refused with a clear error naming the parameter, before any work starts.

"Before any work" is checked literally where it matters: the core simulation constructor is
replaced by a trap, so a check that only happened inside the C++ core (or after stepping) fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph import _core
from terrasph import simulation as simulation_module
from terrasph.config import ConfigError, Material, Numerics, from_mapping
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.scenes.column_collapse import ColumnCollapse
from terrasph.simulation import Simulation

DX = 0.005


@pytest.fixture
def no_core(monkeypatch):
    """Makes building the C++ simulation fail loudly: errors must come before it."""
    def trap(*args, **kwargs):
        raise AssertionError("the core simulation was built although the input is invalid")

    monkeypatch.setattr(simulation_module._core, "Simulation2D", trap)


def block_scene() -> Scene:
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.04, 0.02)
    return scene


@pytest.mark.parametrize("spacing", [0.0, -0.001, math.nan, math.inf])
def test_bad_spacing(spacing) -> None:
    with pytest.raises(ConfigError, match=r"'numerics\.spacing'"):
        Numerics(spacing=spacing)
    with pytest.raises(ConfigError, match=r"'spacing'"):
        Scene(spacing=spacing)
    # a scene configuration refuses it at the latest when the scene is built (ColumnCollapse
    # itself lets spacing = inf through; Numerics then names it)
    from terrasph.scenes.column_collapse import build_column_collapse

    with pytest.raises(ConfigError, match=r"'(numerics\.)?spacing'"):
        build_column_collapse(ColumnCollapse(spacing=spacing))


def test_mu2_below_mu1() -> None:
    with pytest.raises(ConfigError, match=r"'material\.mu2'.*mu2 >= mu1"):
        Material(mu1=0.6, mu2=0.4)
    with pytest.raises(ConfigError, match=r"'friction_angles_deg'"):
        ColumnCollapse(friction_angles_deg=(33.0, 21.0))
    # the core checks it too (a second line of defence for direct users of _core)
    params = _core.ModelParams2D()
    material = params.material
    material.mu1, material.mu2 = 0.6, 0.4
    params.material = material
    with pytest.raises(ValueError, match=r"'material\.mu2'"):
        params.validate()


@pytest.mark.parametrize("name, value", [
    ("mu1", -0.1), ("bulk_stiffness", 0.0), ("bulk_stiffness", -5.0), ("grain_diameter", math.nan),
    ("water_content", 1.5), ("eos_exponent", 0.5), ("model", "plastic"), ("filling_angle", 2.0),
    ("packing_fraction", 1.2), ("mu1", True),
])
def test_bad_material_values_name_the_parameter(name, value) -> None:
    with pytest.raises(ConfigError, match=rf"'material\.{name}'"):
        Material(**{name: value})


@pytest.mark.parametrize("name, value", [
    ("h_factor", 0.9), ("h_factor", 2.5), ("cfl", 0.0), ("cfl", 1.2), ("fixed_dt", -1e-5),
    ("delta_sph", -0.1), ("xsph", 1.5), ("shepard_interval", -1), ("shepard_interval", 2.5),
    ("density_ratio_min", 1.2), ("density_ratio_max", 0.9), ("sound_speed", -1.0),
])
def test_bad_numerics_values_name_the_parameter(name, value) -> None:
    with pytest.raises(ConfigError, match=rf"'numerics\.{name}'"):
        Numerics(**{name: value})


def test_a_step_above_half_the_bound_needs_the_density_advanced_first() -> None:
    """C > 0.5 is refused with the kicked density (forward Euler in velocity and density, measured
    to move a leg's loads by 13-16 % at C = 0.4) and accepted up to 1 with the symplectic one."""
    with pytest.raises(ConfigError, match=r"'numerics\.cfl' = 0\.8 .*symplectic_density"):
        Numerics(cfl=0.8, symplectic_density=False)
    assert Numerics(cfl=1.0, symplectic_density=True).cfl == 1.0


def test_h_factor_out_of_range_in_wall_layers() -> None:
    with pytest.raises(ValueError, match="h_factor"):
        wall_layers_needed(2.5)


def test_unknown_parameters_are_named() -> None:
    with pytest.raises(ConfigError, match=r"unknown parameter 'numerics\.hfactor'"):
        from_mapping(Numerics, {"spacing": DX, "hfactor": 1.3})
    with pytest.raises(ConfigError, match=r"unknown parameter 'material\.friction'"):
        from_mapping(Material, {"friction": 0.5})
    # a scene's numerics overrides go through the same check
    from terrasph.scenes.column_collapse import build_column_collapse

    with pytest.raises(ConfigError, match=r"unknown parameter 'numerics\.delta'"):
        build_column_collapse(ColumnCollapse(numerics={"delta": 0.1}))
    # and keyword arguments of the dataclasses themselves
    with pytest.raises(ConfigError, match=r"unknown parameter 'numerics\.spacingg'"):
        Numerics(spacingg=DX)


def test_grain_density_not_above_reference_density() -> None:
    """Checked only in C++ before (a traceback from the core); now a ConfigError from Material."""
    with pytest.raises(ConfigError, match=r"'material\.grain_density'.*> reference_density"):
        Material(grain_density=2500.0, reference_density=2507.0)


def test_particle_outside_the_domain(no_core) -> None:
    scene = block_scene()
    scene.domain_lower = (0.0, 0.0)
    scene.domain_upper = (0.03, 0.1)  # the block reaches x = 0.04
    with pytest.raises(ConfigError, match=r"outside the domain.*'domain'"):
        Simulation(scene, Material(), Numerics(spacing=DX))


def test_particle_inside_a_wall(no_core) -> None:
    scene = block_scene()
    scene.add_wall("floor", [(-0.01, 0.01), (0.05, 0.01)], layers=wall_layers_needed(1.3))  # cuts the block
    with pytest.raises(ConfigError, match="overlaps a wall"):
        Simulation(scene, Material(), Numerics(spacing=DX))


def test_spacing_mismatch_and_empty_scene(no_core) -> None:
    with pytest.raises(ConfigError, match=r"'numerics\.spacing'"):
        Simulation(block_scene(), Material(), Numerics(spacing=2 * DX))
    with pytest.raises(ConfigError, match=r"no particles|no granular"):
        Simulation(Scene(spacing=DX), Material(), Numerics(spacing=DX))


def test_bad_simulation_arguments(no_core) -> None:
    with pytest.raises(ConfigError, match=r"'width'"):
        Simulation(block_scene(), Material(), Numerics(spacing=DX), width=0.0)
    with pytest.raises(ConfigError, match=r"'material'"):
        Simulation(block_scene(), {"mu1": 0.3}, Numerics(spacing=DX))
    with pytest.raises(ConfigError, match=r"'initial_density'"):
        Simulation(block_scene(), Material(), Numerics(spacing=DX), initial_density=np.ones(3))


def test_bad_run_arguments_fail_before_stepping() -> None:
    sim = Simulation(block_scene(), Material(), Numerics(spacing=DX))
    with pytest.raises(ConfigError, match=r"'t_end'"):
        sim.run(0.0, progress=False)
    with pytest.raises(ConfigError, match=r"'frame_interval'"):
        sim.run(0.01, frame_interval=0.0, progress=False)
    assert sim.step_count == 0


def test_bad_column_collapse_settings() -> None:
    with pytest.raises(ConfigError, match=r"'resolution'"):
        ColumnCollapse(resolution="ultra")
    with pytest.raises(ConfigError, match=r"'floor_length'"):
        ColumnCollapse(floor_length=0.05)
    with pytest.raises(ConfigError, match=r"'t_end'"):
        ColumnCollapse(t_end=-1.0)
