"""Ready-made scenes from the dissertation, and the registry that names them.

Every scene is a configuration dataclass and a ``run(config, *, output, progress, plot, resume,
until)`` function; :data:`SCENES` maps the scene's command-line name to both, so the command line,
``terrasph resume`` and sweeps find a scene by name and rebuild its configuration from a run file.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from terrasph.config import ConfigError
from terrasph.robots.leg_wheel import LegWheel, run_leg_wheel
from terrasph.robots.rover import Rover, run_rover
from terrasph.scenes.column_collapse import (
    RESOLUTIONS,
    ColumnCollapse,
    build_column_collapse,
    run_column_collapse,
)
from terrasph.scenes.leg_rotation import (
    LegRotation,
    build_leg_rotation,
    run_leg_rotation,
)
from terrasph.scenes.plate_intrusion import (
    PlateIntrusion,
    build_plate_intrusion,
    run_plate_intrusion,
)

__all__ = ["RESOLUTIONS", "SCENES", "ColumnCollapse", "LegRotation", "PlateIntrusion", "SceneEntry",
           "build_column_collapse", "build_leg_rotation", "build_plate_intrusion", "run_column_collapse",
           "run_leg_rotation", "run_plate_intrusion", "scene_of_run"]


@dataclass(frozen=True)
class SceneEntry:
    """A scene: its configuration type, where a run file keeps that configuration, its run function."""

    name: str  #: command-line name, also the run file's ``config["scene"]``
    config_key: str  #: key of the scene's configuration in the run file's configuration
    config_type: type
    run: Callable[..., Any]

    def config_from(self, values: Mapping[str, Any]) -> Any:
        """The scene's configuration from its saved form (JSON lists back to the tuples it holds)."""
        fields = {f.name: f for f in dataclasses.fields(self.config_type)}
        unknown = sorted(set(values) - set(fields))
        if unknown:
            raise ConfigError(f"the saved {self.name} configuration has unknown entries {unknown}")
        converted = {key: tuple(value) if isinstance(value, list) and isinstance(fields[key].default, tuple) else value
                     for key, value in values.items()}
        return self.config_type(**converted)


SCENES: dict[str, SceneEntry] = {entry.name: entry for entry in (
    SceneEntry("column-collapse", "column_collapse", ColumnCollapse, run_column_collapse),
    SceneEntry("leg-rotation", "leg_rotation", LegRotation, run_leg_rotation),
    SceneEntry("plate-intrusion", "plate_intrusion", PlateIntrusion, run_plate_intrusion),
    SceneEntry("leg-wheel", "leg_wheel", LegWheel, run_leg_wheel),
    SceneEntry("rover", "rover", Rover, run_rover),
)}


def scene_of_run(config_json: str) -> tuple[SceneEntry, Any]:
    """The scene and its configuration from a run file's ``config_json`` attribute."""
    config = json.loads(config_json)
    name = config.get("scene")
    if name not in SCENES:
        raise ConfigError(f"the run was not made by a registered scene (scene = {name!r}; "
                          f"known: {', '.join(SCENES)}), so it cannot be resumed by name")
    entry = SCENES[name]
    return entry, entry.config_from(config[entry.config_key])
