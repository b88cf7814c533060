"""One definition per parameter: Python and C++ agree on every default and range.

The parameter lists live in cpp/include/terrasph/params.hpp. Python's Material/Numerics are
generated from the table the core exports, and the core's structs from the same lists, so a
drift between the languages would show up here: a default that differs, a bound that one side
enforces and the other does not, a field bound in one place and missing in the other, or a rule
linking two parameters that escapes as a traceback instead of a ConfigError.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

import numpy as np
import pytest
from terrasph import _core
from terrasph.config import PARAMETERS, ConfigError, Material, Numerics, Parameter, from_mapping, parameter
from terrasph.scene import Scene
from terrasph.simulation import Simulation

PYTHON_CLASS = {"material": Material, "numerics": Numerics}
CORE_CLASS = {"material": _core.MaterialParams, "numerics": _core.NumericsParams}

#: values of other parameters that a bound needs so that no rule linking parameters refuses it
#: (μ2 = 0 is only admissible with μ1 = 0, a step above C = 0.5 only with the density advanced first)
COMPANIONS: dict[str, dict[str, Any]] = {"material.mu2": {"mu1": 0.0}, "numerics.cfl": {"symplectic_density": True}}


def core_struct(group: str, values: dict[str, Any]) -> Any:
    """The core's struct for ``group`` with ``values`` set through the bindings (no Python checks)."""
    struct = CORE_CLASS[group]()
    for name, value in values.items():
        setattr(struct, name, value)
    return struct


def bound_cases() -> list[tuple[Parameter, float, bool]]:
    """(parameter, value, admissible) on both sides of every bound of every numeric parameter.

    An inclusive bound is admissible and its next representable neighbour outside is not (for an
    int, the next integer); an exclusive bound is itself outside. An open end at ±inf refuses
    ±inf (a double must be finite); an int has no infinite value to try.
    """
    cases = []
    for entry in PARAMETERS:
        if entry.kind not in ("double", "int"):
            continue
        for bound, inclusive, outward in ((entry.lower, entry.lower_inclusive, -math.inf),
                                          (entry.upper, entry.upper_inclusive, math.inf)):
            if math.isinf(bound):
                assert not inclusive, f"{entry.qualified_name}: an infinite bound must be exclusive"
                if entry.kind == "double":
                    cases.append((entry, bound, False))
                continue
            if entry.kind == "int":
                bound = int(bound)
            if inclusive:
                step_out = int(math.copysign(1, outward))
                outside = bound + step_out if entry.kind == "int" else math.nextafter(bound, outward)
                cases.append((entry, bound, True))
                cases.append((entry, outside, False))
            else:
                cases.append((entry, bound, False))
    return cases


def case_id(case: tuple[Parameter, float, bool]) -> str:
    entry, value, admissible = case
    return f"{entry.qualified_name}={value!r}:{'ok' if admissible else 'refused'}"


def test_the_table_covers_both_classes_and_every_bound_field() -> None:
    for group, cls in PYTHON_CLASS.items():
        table_names = [entry.name for entry in PARAMETERS if entry.group == group]
        assert [f.name for f in dataclasses.fields(cls)] == table_names
        # every attribute the bindings expose is a parameter of the table, and vice versa
        bound = sorted(name for name, value in vars(CORE_CLASS[group]).items() if isinstance(value, property))
        assert bound == sorted(table_names)
    assert len({entry.qualified_name for entry in PARAMETERS}) == len(PARAMETERS)


@pytest.mark.parametrize("entry", PARAMETERS, ids=lambda entry: entry.qualified_name)
def test_python_default_equals_the_core_struct_default(entry: Parameter) -> None:
    python_default = getattr(PYTHON_CLASS[entry.group](), entry.name)
    core_default = getattr(CORE_CLASS[entry.group](), entry.name)
    assert type(python_default) is entry.python_type
    assert python_default == core_default
    assert type(core_default) is type(python_default)
    field = next(f for f in dataclasses.fields(PYTHON_CLASS[entry.group]) if f.name == entry.name)
    assert field.metadata["unit"] == entry.unit and field.metadata["doc"] == entry.doc


def test_defaults_are_the_documented_values() -> None:
    """The defaults that the docs and Table 2.1 state, against the generated classes."""
    material, numerics = Material(), Numerics()
    assert material.mu1 == math.tan(math.radians(21.0)) and material.mu2 == math.tan(math.radians(33.0))
    assert material.filling_angle == math.radians(15.0)
    # ρ0 = ν ρ_s, the bulk density of the beads at the default packing fraction (not Table 2.1's 2507)
    assert (material.grain_density, material.grain_diameter) == (2532.0, 0.002)
    assert material.reference_density == pytest.approx(material.packing_fraction * material.grain_density, rel=1e-12)
    assert material.model == "mu_i_hypoelastic"
    assert (numerics.spacing, numerics.h_factor, numerics.xsph) == (0.0026, 1.3, 0.2)


@pytest.mark.parametrize("case", bound_cases(), ids=case_id)
def test_python_and_core_agree_on_each_bound(case: tuple[Parameter, float, bool]) -> None:
    entry, value, admissible = case
    values = {**COMPANIONS.get(entry.qualified_name, {}), entry.name: value} if admissible else {entry.name: value}
    core = core_struct(entry.group, values)
    if admissible:
        PYTHON_CLASS[entry.group](**values)
        core.validate()
    else:
        named = rf"parameter '{re.escape(entry.qualified_name)}' = .* is invalid: allowed"
        with pytest.raises(ConfigError, match=named):
            PYTHON_CLASS[entry.group](**values)
        with pytest.raises(ValueError, match=named):
            core.validate()


def test_nan_is_refused_for_every_real_parameter() -> None:
    for entry in PARAMETERS:
        if entry.kind == "double":
            with pytest.raises(ConfigError, match=rf"'{entry.qualified_name}'"):
                PYTHON_CLASS[entry.group](**{entry.name: math.nan})
            with pytest.raises(ValueError, match=rf"'{entry.qualified_name}'"):
                core_struct(entry.group, {entry.name: math.nan}).validate()


def test_choices_agree() -> None:
    model = parameter("material.model")
    assert model.kind == "choice" and model.choices == ("mu_i_rate", "mu_i_hypoelastic", "drucker_prager",
                                                        "mu_i_strain")
    for choice in model.choices:
        assert Material(model=choice).model == choice
        assert core_struct("material", {"model": choice}).model == choice
    with pytest.raises(ConfigError, match=r"'material\.model' = 'elastic' is invalid: allowed one of 'mu_i_rate'"):
        Material(model="elastic")
    with pytest.raises(ValueError, match=r"'material\.model' = 'elastic'"):
        core_struct("material", {"model": "elastic"})


@pytest.mark.parametrize("values, named", [
    ({"mu1": 0.6, "mu2": 0.4}, "material.mu2"),
    ({"grain_density": 2500.0, "reference_density": 2507.0}, "material.grain_density"),
    ({"grain_density": 2507.0, "reference_density": 2507.0}, "material.grain_density"),
])
def test_rules_linking_parameters_give_config_errors(values: dict[str, float], named: str) -> None:
    with pytest.raises(ConfigError, match=rf"'{re.escape(named)}'"):
        Material(**values)
    with pytest.raises(ConfigError, match=rf"'{re.escape(named)}'"):
        from_mapping(Material, values)
    with pytest.raises(ValueError, match=rf"'{re.escape(named)}'"):
        core_struct("material", values).validate()
    params = _core.ModelParams2D()
    params.material = core_struct("material", values)
    with pytest.raises(ValueError, match=rf"'{re.escape(named)}'"):
        params.validate()


@pytest.mark.parametrize("group, name, value", [
    ("material", "mu1", True), ("material", "mu1", "0.4"), ("material", "grain_diameter", None),
    ("material", "model", 1), ("numerics", "shepard_interval", 2.0), ("numerics", "shepard_interval", True),
    ("numerics", "shepard_interval", 2**40), ("numerics", "kernel_gradient_correction", 1),
    ("numerics", "spacing", 10**400),
])
def test_values_of_the_wrong_type_name_the_parameter(group: str, name: str, value: Any) -> None:
    with pytest.raises(ConfigError, match=rf"parameter '{group}\.{name}' = .* is invalid: allowed"):
        PYTHON_CLASS[group](**{name: value})


def test_numpy_scalars_and_ints_are_converted_to_the_parameter_type() -> None:
    numerics = Numerics(spacing=np.float32(0.004), shepard_interval=np.int64(5),
                        kernel_gradient_correction=np.bool_(True))
    assert type(numerics.spacing) is float and type(numerics.shepard_interval) is int
    assert numerics.kernel_gradient_correction is True
    assert type(Material(grain_density=3000).grain_density) is float


def test_unknown_keywords_are_config_errors() -> None:
    with pytest.raises(ConfigError, match=r"unknown parameter 'material\.quasi_static'"):
        Material(quasi_static="elastic")
    with pytest.raises(ConfigError, match=r"unknown parameter 'numerics\.hfactor'"):
        Numerics(hfactor=1.3)


def test_docstrings_list_every_parameter_with_default_and_range() -> None:
    for entry in PARAMETERS:
        doc = PYTHON_CLASS[entry.group].__doc__
        assert f"{entry.name}: {entry.python_type.__name__} = {entry.default!r}; allowed {entry.allowed}" in doc
        assert entry.doc in doc


# -- wet cohesion (Eq. 2.33–2.34) -------------------------------------------------------------------
def test_cohesion_of_table_2_1_equals_the_hand_value() -> None:
    """Table 2.1, wet: d = 2 mm, γ_s = 72.5 mN/m, φ = 15°, k = 6; ν = 0.6 (the default), w = 0.5 %.

    By hand: r = 1 mm; tan(7.5°) = 0.131652; F = 2π·1e-3·0.0725/1.131652 = 4.02536e-4 N (Eq. 2.34);
    c = 0.6·6·4.02536e-4/(π·4e-6) = 115.318 Pa (Eq. 2.33).
    """
    material = Material.wet(0.005, surface_tension=0.0725, filling_angle=math.radians(15.0), bridges_per_grain=6.0,
                            packing_fraction=0.6, grain_diameter=0.002, reference_density=2507.0)
    assert material.cohesion == pytest.approx(115.318, rel=1e-5)
    assert material.grain_density == pytest.approx(2532 * 1.005)
    assert material.reference_density == pytest.approx(2507 * 1.005)


def test_cohesion_laws() -> None:
    """c = 0 when dry; c ∝ γ_s, c ∝ k ν, c ∝ 1/d; it falls as the filling angle opens (1 + tan(φ/2))."""
    wet = Material.wet(0.01)
    assert Material().cohesion == 0.0
    assert Material.wet(0.01, surface_tension=0.145).cohesion == pytest.approx(2 * wet.cohesion, rel=1e-12)
    assert Material.wet(0.01, bridges_per_grain=3.0, packing_fraction=0.3).cohesion == pytest.approx(
        wet.cohesion / 4, rel=1e-12)
    assert Material.wet(0.01, grain_diameter=0.004).cohesion == pytest.approx(wet.cohesion / 2, rel=1e-12)
    flat = Material.wet(0.01, filling_angle=0.0).cohesion
    assert flat / wet.cohesion == pytest.approx(1 + math.tan(math.radians(7.5)), rel=1e-12)
    # the core computes the same number from the same struct
    assert wet.to_core().cohesion() == wet.cohesion


# -- derived uses: run-file units and CLI help ------------------------------------------------------
def test_run_file_configuration_carries_each_parameter_unit() -> None:
    scene = Scene(spacing=0.005)
    scene.add_block(0.0, 0.0, 0.02, 0.02)
    described = Simulation(scene, Material(), Numerics(spacing=0.005)).describe()
    units = described["parameter_units"]
    for entry in PARAMETERS:
        assert units[entry.group][entry.name] == entry.unit
    assert units["material"]["grain_density"] == "kg/m^3" and units["numerics"]["fixed_dt"] == "s"
    assert set(described["material"]) == set(units["material"])  # a value for each unit, a unit for each value


def test_cli_help_of_water_content_comes_from_the_table(capsys) -> None:
    from terrasph.cli import main

    with pytest.raises(SystemExit):
        main(["run", "column-collapse", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "0 <= water_content < 1" in text
    assert " ".join(parameter("material.water_content").doc.split()) in text
