"""Validated, documented configuration: granular material and numerical settings.

Each parameter (name, default, unit, allowed range, one-line doc) is defined once, in the C++
core's lists (``cpp/include/terrasph/params.hpp``), which the core exports as
``_core.parameter_table()``. :class:`Material` and :class:`Numerics` are generated from that table:
their fields, defaults, types and docstrings, and their validation, which is the core's own
(range of each parameter, then the rules linking parameters). A bad, unknown or mistyped
parameter raises :class:`ConfigError` naming it and its allowed range, before any work starts.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

import numpy as np

from terrasph import _core

__all__ = ["PARAMETERS", "ConfigError", "Material", "Numerics", "Parameter", "as_dict", "check_settle_time",
           "from_mapping", "glass_beads", "parameter", "parameter_units"]


class ConfigError(ValueError):
    """A configuration value is missing, unknown or outside its allowed range."""


_PYTHON_TYPES: dict[str, type] = {"double": float, "int": int, "bool": bool, "choice": str}


@dataclass(frozen=True)
class Parameter:
    """One configuration parameter as the core defines it (an entry of ``_core.parameter_table()``)."""

    group: str  #: "material" or "numerics"
    name: str
    kind: str  #: "double", "int", "bool" or "choice"
    default: Any
    unit: str  #: SI unit; "1" for a pure number
    lower: float  #: the allowed interval of a number (±inf when open-ended)
    lower_inclusive: bool
    upper: float
    upper_inclusive: bool
    choices: tuple[str, ...]  #: the allowed values of a choice
    allowed: str  #: the allowed range as the error messages state it
    doc: str

    @property
    def qualified_name(self) -> str:
        """``group.name``, as error messages name the parameter."""
        return f"{self.group}.{self.name}"

    @property
    def python_type(self) -> type:
        """The Python type of the value: float, int, bool or str."""
        return _PYTHON_TYPES[self.kind]

    def help(self) -> str:
        """One line for docstrings and command-line help: doc, default and allowed range."""
        return f"{self.doc} (default {self.default!r}; allowed {self.allowed})"

    def coerce(self, value: Any) -> Any:
        """``value`` as this parameter's Python type; ConfigError if it is not of that type.

        A bool is not accepted for a number, nor a float for an int; numpy scalars are accepted.
        """
        is_bool = isinstance(value, (bool, np.bool_))
        if self.kind == "double" and isinstance(value, numbers.Real) and not is_bool:
            try:
                return float(value)
            except OverflowError:
                pass
        elif self.kind == "int" and isinstance(value, numbers.Integral) and not is_bool:
            return int(value)
        elif (self.kind == "bool" and is_bool) or (self.kind == "choice" and isinstance(value, str)):
            return bool(value) if is_bool else value
        allowed = {"double": f"a real number, {self.allowed}", "int": f"an integer, {self.allowed}",
                   "bool": "True or False"}.get(self.kind, self.allowed)
        raise ConfigError(f"parameter '{self.qualified_name}' = {value!r} is invalid: allowed {allowed}")


#: Every material and numerics parameter, in the core's order.
PARAMETERS: tuple[Parameter, ...] = tuple(
    Parameter(**{**entry, "choices": tuple(entry["choices"])}) for entry in _core.parameter_table())


def parameter(qualified_name: str) -> Parameter:
    """The parameter called ``group.name``, e.g. ``parameter("material.water_content")``."""
    for entry in PARAMETERS:
        if entry.qualified_name == qualified_name:
            return entry
    raise KeyError(qualified_name)


def parameter_units() -> dict[str, dict[str, str]]:
    """Unit of every parameter by group and name (saved beside the configuration in run files)."""
    units: dict[str, dict[str, str]] = {}
    for entry in PARAMETERS:
        units.setdefault(entry.group, {})[entry.name] = entry.unit
    return units


class _ParameterGroup:
    """What Material and Numerics share: keyword-only construction from the core's table, values
    coerced to their types and checked by the core's validate()."""

    _group: ClassVar[str]
    _core_class: ClassVar[type]
    _parameters: ClassVar[tuple[Parameter, ...]]

    if TYPE_CHECKING:
        # The fields are made from the core's parameter table as the module loads (_from_table),
        # so a type checker sees a dataclass whose attributes are any parameter's value.
        __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

        def __getattr__(self, name: str) -> Any: ...

    def __new__(cls, *args: Any, **kwargs: Any) -> Any:
        _reject_unknown(cls, kwargs)
        return super().__new__(cls)

    def __post_init__(self) -> None:
        for entry in self._parameters:
            object.__setattr__(self, entry.name, entry.coerce(getattr(self, entry.name)))
        try:
            self.to_core().validate()
        except ValueError as error:
            raise ConfigError(str(error)) from None

    def to_core(self) -> Any:
        """The core's parameter struct (``_core.MaterialParams`` / ``NumericsParams``) with these values."""
        core = self._core_class()
        for entry in self._parameters:
            value = getattr(self, entry.name)
            try:
                setattr(core, entry.name, value)
            except ValueError as error:  # a choice the core does not know
                raise ConfigError(str(error)) from None
            except TypeError:  # e.g. an int beyond the core's int
                raise ConfigError(f"parameter '{entry.qualified_name}' = {value!r} is invalid: allowed "
                                  f"{entry.allowed}") from None
        return core


def _reject_unknown(cls: type[_ParameterGroup], names: Mapping[str, Any]) -> None:
    known = [entry.name for entry in cls._parameters]
    for name in names:
        if name not in known:
            raise ConfigError(f"unknown parameter '{cls._group}.{name}'; known: {', '.join(sorted(known))}")


def _docstring(summary: str, parameters: tuple[Parameter, ...]) -> str:
    lines = [summary.rstrip(), "", "Parameters (keyword only; defined in cpp/include/terrasph/params.hpp):", ""]
    for entry in parameters:
        lines.append(f"{entry.name}: {entry.python_type.__name__} = {entry.default!r}; allowed {entry.allowed}")
        lines.append(f"    {entry.doc}")
    return "\n".join(lines)


def _from_table(group: str, core_class: type) -> Callable[[type], type]:
    """Class decorator: makes ``cls`` a frozen, keyword-only dataclass with one field per parameter
    of ``group`` in the core's table (type, default, unit/range/doc in the field metadata)."""

    def build(cls: type) -> type:
        parameters = tuple(entry for entry in PARAMETERS if entry.group == group)
        cls.__annotations__ = {entry.name: entry.python_type for entry in parameters}
        for entry in parameters:
            setattr(cls, entry.name, dataclasses.field(
                default=entry.default, metadata={"unit": entry.unit, "allowed": entry.allowed, "doc": entry.doc}))
        cls._group, cls._core_class, cls._parameters = group, core_class, parameters  # type: ignore[attr-defined]
        cls.__doc__ = _docstring(cls.__doc__ or "", parameters)
        return dataclass(frozen=True, kw_only=True)(cls)

    return build


@_from_table("material", _core.MaterialParams)
class Material(_ParameterGroup):
    """Granular material for the μ(I) rheology (Eq. 2.29–2.34), SI units.

    Defaults are the dry glass beads of the column collapse (Table 2.1, μ1 = tan 21°, μ2 = tan 33°).
    Densities of a wet material scale with (1 + w) (Table 2.1); use :meth:`wet`. ``model`` is
    ``"mu_i_hypoelastic"`` (default: a hypoelastic–plastic μ(I), the deviatoric stress is state,
    loaded with the Jaumann rate and capped at μ(I)P + c, so a bed at rest holds shear),
    ``"mu_i_rate"`` (the rate form of Eq. 2.29 everywhere), ``"drucker_prager"`` (Eq. 2.17–2.28
    with the Jaumann rate) or ``"mu_i_strain"`` (Eq. 3.6: the small strain's direction for
    I ≤ 0.001).
    """

    @property
    def cohesion(self) -> float:
        """Capillary cohesion c (Pa) of a pendular wet material, 0 when dry.

        c = ν k F / (π d²) (Rumpf; Eq. 2.33) with the mean bridge force
        F = 2π r γ_s / (1 + tan(φ/2)) (Eq. 2.34), r = d/2. Computed by the core.
        """
        return float(self.to_core().cohesion())

    @classmethod
    def wet(cls, water_content: float, **overrides: Any) -> Material:
        """Glass beads with water content w: densities scaled by (1 + w) as in Table 2.1."""
        base = cls(**overrides)
        return dataclasses.replace(base, water_content=water_content,
                                   grain_density=base.grain_density * (1 + water_content),
                                   reference_density=base.reference_density * (1 + water_content))


@_from_table("numerics", _core.NumericsParams)
class Numerics(_ParameterGroup):
    """Discretisation and optional numerical terms; a term set to 0 is switched off and costs nothing.

    ``h_factor`` = 1.3 is the default (h = 1.3 Δx, about 21 neighbours in 2D with the Wendland C2
    support 2h), inside the usual 1.2–1.5 range.
    """

    @property
    def smoothing_length(self) -> float:
        """h = h_factor·Δx (m)."""
        return self.h_factor * self.spacing


def glass_beads() -> Material:
    """3 mm glass beads of chapter 3: ρ_s = 2600 kg/m³ at packing 0.63 (ρ0 = 1638 kg/m³),
    μ1 = tan 23°, μ2 = tan 33°, κ = 30 000 Pa."""
    return Material(grain_density=2600.0, reference_density=2600.0 * 0.63, grain_diameter=0.003,
                    mu1=math.tan(math.radians(23.0)), mu2=math.tan(math.radians(33.0)),
                    bulk_stiffness=30000.0, packing_fraction=0.63)


T = TypeVar("T", Material, Numerics)


def check_settle_time(settle_time: Any, t_end: Any, name: str = "settle_time") -> None:
    """The one rule of a scene's settling pause and its end time: the pause `settle_time` (s) is a
    finite number in [0, t_end), so every run has a phase after it (a run that ends in its pause
    never drives, never pushes, never turns: its summary would be all undefined). `t_end` None is the
    scene's own end, after the pause by construction. ConfigError naming the parameter otherwise,
    before any work; the same in every scene."""
    if isinstance(settle_time, bool) or not isinstance(settle_time, numbers.Real) or not (
            math.isfinite(float(settle_time)) and float(settle_time) >= 0):
        raise ConfigError(f"parameter '{name}' = {settle_time!r} is invalid: allowed a finite number >= 0 s")
    if t_end is not None and not settle_time < t_end:
        raise ConfigError(f"parameter '{name}' = {settle_time!r} is invalid: allowed in [0, t_end = {t_end!r}) s "
                          "(the run would end before its pause does)")


def from_mapping(cls: type[T], values: Mapping[str, Any]) -> T:
    """Build ``cls`` from a mapping, rejecting unknown keys by name."""
    return cls(**dict(values))


def as_dict(obj: Material | Numerics) -> dict[str, Any]:
    """Plain dict of a configuration object (for HDF5 attributes and JSON)."""
    return dataclasses.asdict(obj)
