"""Column-collapse material presets: the packing's bulk density is the default (ρ0 = ν ρ_s, the
material's own default) and Table 2.1's is a named preset. Reference: Eq. 2.44, c0 = √(κγρ_s/(ρ0(ρ_s − ρ0))), evaluated
by hand: Table 2.1 (ρ0 = 2507 kg/m³, ρ_s = 2532 kg/m³, κ = 28 kPa, γ = 7) gives 88.98 m/s; the
packed preset (ρ0 = 0.6·2532 = 1519.2 kg/m³) 17.96 m/s."""

from __future__ import annotations

import math

import pytest
from terrasph.config import ConfigError
from terrasph.scenes.column_collapse import ColumnCollapse


def sound_speed(preset: str) -> float:
    m = ColumnCollapse(material_preset=preset).material()
    return math.sqrt(m.bulk_stiffness * m.eos_exponent * m.grain_density /
                     (m.reference_density * (m.grain_density - m.reference_density)))


def test_presets_give_the_stated_densities_and_sound_speeds() -> None:
    assert ColumnCollapse().material().reference_density == pytest.approx(1519.2)  # the packing's
    assert ColumnCollapse(material_preset="table_2_1").material().reference_density == 2507.0
    assert sound_speed("table_2_1") == pytest.approx(88.98, abs=0.01)
    assert ColumnCollapse(material_preset="packed").material().reference_density == pytest.approx(1519.2)
    assert sound_speed("packed") == pytest.approx(17.96, abs=0.01)


def test_an_unknown_preset_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="material_preset"):
        ColumnCollapse(material_preset="loose")
