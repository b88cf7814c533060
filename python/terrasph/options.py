"""Scene options defined once: a scene's configuration dataclass marks each field the command line
offers with :func:`option` (help, unit, choices, command-line name), and :func:`add_config_options`
turns those fields into ``terrasph run SCENE`` options, as ``params.hpp`` defines the physics
parameters once for C++, Python and the docs.

The option of field ``settle_time`` is ``--settle-time``, unless the field names another. A field
that is a tuple is one option taking as many values, or one option per element when the field
names one per element (e.g. ``--mu1-deg`` and ``--mu2-deg`` of ``friction_angles_deg``). A field
marked ``repeat`` is an option given any number of times (a tuple of its values, or a dict of
``NAME=VALUE`` pairs its ``parse`` returns), one marked ``positional`` a required argument. The
values a user leaves out are not passed, so the dataclass's own defaults apply, and its own checks
(``__post_init__``) judge the ranges: one definition of each default and each range.
"""

from __future__ import annotations

import argparse
import dataclasses
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["OPTION", "SHARED", "Option", "add_config_options", "check_unused_fields", "config_values", "option",
           "option_name", "redefault",
           "shared", "with_option_names"]

#: the key of a field's metadata that holds its :class:`Option`
OPTION = "terrasph.option"


@dataclass(frozen=True)
class Option:
    """What the command line shows of one configuration field."""

    help: str  #: what the value means (one phrase, no default: the field's default is appended)
    unit: str = ""  #: SI unit shown as [unit]
    choices: tuple[str, ...] | None = None  #: the allowed values of a text field
    cli: str | tuple[str, ...] | None = None  #: option name(s) without "--"; default: the field's name
    default_text: str | None = None  #: the default in words, where the value is None or computed
    #: named presets of this (numeric) field: adds ``--resolution NAME`` setting it, unless given itself
    presets: Mapping[str, float] | None = None
    positional: bool = False  #: a required argument (its metavar: ``cli``), not an option
    repeat: bool = False  #: an option given any number of times; the field is a tuple or a dict
    parse: Callable[[str], Any] | None = None  #: argparse type of a repeated value (a pair for a dict)


def option(default: Any = dataclasses.MISSING, *, help: str, unit: str = "",
           choices: tuple[str, ...] | list[str] | None = None, cli: str | tuple[str, ...] | None = None,
           default_text: str | None = None, presets: Mapping[str, float] | None = None, positional: bool = False,
           repeat: bool = False, parse: Callable[[str], Any] | None = None,
           default_factory: Callable[[], Any] | None = None) -> Any:
    """A dataclass field with a default (or `default_factory`) that the command line offers as an
    option (or, `positional`, as a required argument)."""
    meta = Option(help, unit, tuple(choices) if choices is not None else None, cli, default_text, presets,
                  positional, repeat, parse)
    if default_factory is not None:
        return dataclasses.field(default_factory=default_factory, metadata={OPTION: meta})
    return dataclasses.field(default=default, metadata={OPTION: meta})


#: the options several scenes share, written once: each scene gives only its default (:func:`shared`)
SHARED: dict[str, Option] = {
    "bed_width": Option("width of the bed of grains", "m"),
    "bed_depth": Option("depth of the bed of grains", "m"),
    "leg_length": Option("hip-to-toe length of a leg", "m"),
    "settle_time": Option("pause before the motion starts, while the bed settles", "s"),
    "t_end": Option("simulated time", "s"),
    "frame_interval": Option("time between saved frames", "s"),
    "mu1_deg": Option("the bed's quasi-static friction angle atan mu1 (Eq. 2.31)", "degrees"),
    "mu2_deg": Option("the bed's dynamic friction angle atan mu2, >= mu1-deg", "degrees"),
    "water_content": Option("the bed's water content w; > 0: wet beads with cohesion (Table 2.1)", "kg/kg"),
    "terrain": Option("the SPH bed, or resistive force theory on a flat surface (terrasph.terrain.rft, docs/rft.md)",
                      choices=("sph", "rft")),
    "rft_table": Option('terrain rft: the coefficient map, "generic" or a JSON table (terrasph rft-calibrate)'),
}


def shared(name: str, default: Any, **changes: Any) -> Any:
    """A dataclass field for the shared option `name` (:data:`SHARED`) with this scene's default
    and any of its Option attributes changed (e.g. ``default_text``)."""
    meta = dataclasses.replace(SHARED[name], **changes)
    return dataclasses.field(default=default, metadata={OPTION: meta})


def redefault(config_type: type, name: str, default: Any) -> Any:
    """The field `name` of `config_type` (help, unit, …) with another default, for a subclass."""
    inherited = config_type.__dataclass_fields__[name]  # type: ignore[attr-defined]
    return dataclasses.field(default=default, metadata=inherited.metadata)


def check_unused_fields(config: Any, names: tuple[str, ...], why: str) -> None:
    """ConfigError in one line naming the first of the fields `names` of the dataclass `config` that
    differs from its default: a setting its `terrain` has no use for (`why` says so) is refused
    rather than ignored."""
    from terrasph.config import ConfigError

    for item in dataclasses.fields(config):
        if item.name not in names:
            continue
        default = item.default if item.default_factory is dataclasses.MISSING else item.default_factory()
        value = getattr(config, item.name)
        if value != default:
            raise ConfigError(f"parameter '{item.name}' = {value!r} is invalid on terrain {config.terrain!r}: allowed "
                              f"only its default {default!r} there ({why})")


def option_name(field_name: str) -> str:
    """``--settle-time`` for the field ``settle_time``."""
    return "--" + field_name.replace("_", "-")


def _offered(config_type: type) -> list[tuple[dataclasses.Field[Any], Option, Any]]:
    """The fields of `config_type` with an option, each with its Option and resolved type."""
    hints = typing.get_type_hints(config_type)
    return [(f, f.metadata[OPTION], hints[f.name]) for f in dataclasses.fields(config_type) if OPTION in f.metadata]


def _value_type(annotation: Any) -> Any:
    """The type of a field's values: ``float`` of ``float``, ``float | None`` …"""
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        return next(a for a in typing.get_args(annotation) if a is not type(None))
    return annotation


def _option_names(f: dataclasses.Field[Any], meta: Option) -> tuple[str, ...]:
    """The options of a field: one per element of a tuple field that names one each, else one."""
    if isinstance(meta.cli, tuple):
        return tuple(f"--{name}" for name in meta.cli)
    return (f"--{meta.cli}" if meta.cli else option_name(f.name),)


def _help(meta: Option, default: Any) -> str:
    unit = f" [{meta.unit}]" if meta.unit else ""
    shown = meta.default_text if meta.default_text is not None else default
    if isinstance(shown, tuple):
        shown = " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in shown)
    elif isinstance(shown, float):
        shown = f"{shown:g}"
    return f"{meta.help}{unit} (default {shown})".replace("%", "%%")


def add_config_options(parser: argparse.ArgumentParser, config_type: type) -> None:
    """Adds one option per offered field of `config_type` (see the module's docstring); the
    parsed values come back with :func:`config_values`."""
    for f, meta, annotation in _offered(config_type):
        value_type, dest, names = _value_type(annotation), f"config__{f.name}", _option_names(f, meta)
        if meta.positional:
            parser.add_argument(dest, metavar=meta.cli or f.name.upper(), type=value_type,
                                help=f"{meta.help}" + (f" [{meta.unit}]" if meta.unit else ""))
        elif meta.repeat:
            parser.add_argument(names[0], dest=dest, action="append", type=meta.parse or str, default=argparse.SUPPRESS,
                                metavar=meta.unit or f.name.upper(),
                                help=f"{meta.help}, repeatable (default {meta.default_text or 'none'})")
        elif isinstance(meta.cli, tuple):  # a tuple field, one option per element
            element = typing.get_args(value_type)[0]
            for index, name in enumerate(names):
                parser.add_argument(name, dest=f"{dest}__{index}", type=element, default=argparse.SUPPRESS,
                                    metavar=name[2:].upper().replace("-", "_"), help=_help(meta, f.default[index]))
        elif typing.get_origin(value_type) is tuple:  # a tuple field, one option taking every element
            size = len(typing.get_args(value_type))  # tuple[float, float]: 2, whatever the default (None, say)
            parser.add_argument(names[0], dest=dest, type=typing.get_args(value_type)[0], nargs=size,
                                metavar=tuple(f"V{i + 1}" for i in range(size)),
                                default=argparse.SUPPRESS, help=_help(meta, f.default))
        elif value_type is bool:
            parser.add_argument(names[0], dest=dest, action=argparse.BooleanOptionalAction, default=argparse.SUPPRESS,
                                help=_help(meta, f.default))
        else:
            parser.add_argument(names[0], dest=dest, type=value_type, choices=meta.choices, default=argparse.SUPPRESS,
                                metavar=None if meta.choices else f.name.upper(), help=_help(meta, f.default))
        if meta.presets is not None:
            sizes = ", ".join(f"{key} {value * 1e3:g} mm" for key, value in meta.presets.items())
            parser.add_argument("--resolution", dest=f"{dest}__preset", choices=list(meta.presets),
                                default=argparse.SUPPRESS,
                                help=f"a named {f.name}: {sizes} (default {f.default:g} m; {names[0]} overrides it)")


def with_option_names(message: str, config_type: type) -> str:
    """`message` (a ConfigError's) with the option beside each offered field it names:
    "parameter 'settle_time' (--settle-time) = ..."."""
    for f, meta, _ in _offered(config_type):
        names = (meta.cli or f.name.upper(),) if meta.positional else _option_names(f, meta)  # an argument: no "--"
        message = message.replace(f"'{f.name}'", f"'{f.name}' ({', '.join(names)})")
    return message


def config_values(args: argparse.Namespace, config_type: type) -> dict[str, Any]:
    """The configuration fields the user set on the command line, by name (the others keep the
    dataclass's defaults)."""
    given = vars(args)
    values: dict[str, Any] = {}
    for f, meta, _ in _offered(config_type):
        dest = f"config__{f.name}"
        if isinstance(meta.cli, tuple):
            parts = [given.get(f"{dest}__{i}", default) for i, default in enumerate(f.default)]
            if any(f"{dest}__{i}" in given for i in range(len(parts))):
                values[f.name] = tuple(parts)
        elif dest in given and meta.repeat and f.default_factory is dict:  # NAME=VALUE pairs
            values[f.name] = dict(given[dest])
        elif dest in given:
            values[f.name] = tuple(given[dest]) if isinstance(given[dest], list) else given[dest]
        elif meta.presets is not None and f"{dest}__preset" in given:
            values[f.name] = meta.presets[given[f"{dest}__preset"]]
    return values
