"""Ready-made scenes from the dissertation, and the registry that names them.

Every scene is a configuration dataclass and a ``run(config, *, output, progress, ...)`` function
(and ``resume`` and ``until``); :data:`SCENES` maps the scene's
command-line name to both, so the command line, ``terrasph resume`` and sweeps find a scene by
name and rebuild its configuration from a run file, and :func:`run_case` runs any of them.
The robot scenes (leg_wheel, rover, mjcf_scene: on terrasph.terrain) and plate_drag are imported on
first use, so importing the registry (and the plain SPH scenes) loads no MuJoCo.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from terrasph.config import ConfigError
from terrasph.io import defined_values
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

__all__ = ["RESOLUTIONS", "SCENES", "CaseSummary", "ColumnCollapse", "LegRotation", "PlateIntrusion", "SceneEntry",
           "build_column_collapse", "build_leg_rotation", "build_plate_intrusion", "run_case", "run_column_collapse",
           "run_leg_rotation", "run_plate_intrusion", "scene_entry", "scene_of_run"]


@dataclass(frozen=True)
class SceneEntry:
    """A scene: its configuration type, where a run file keeps that configuration, its run function
    (both named in `module`, imported on first use)."""

    name: str  #: command-line name, also the run file's ``config["scene"]``
    config_key: str  #: key of the scene's configuration in the run file's configuration
    module: str
    config_class: str
    run_function: str
    help: str = ""  #: one line for ``terrasph run --help``
    description: str = ""  #: the paragraph of ``terrasph run NAME --help``

    @property
    def config_type(self) -> type:
        """The scene's configuration dataclass."""
        return getattr(importlib.import_module(self.module), self.config_class)

    @property
    def run(self) -> Callable[..., Any]:
        """The scene's run function."""
        return getattr(importlib.import_module(self.module), self.run_function)

    def current_names(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """`values` with the fields earlier versions saved under other names renamed (the
        configuration's ``RENAMED_FIELDS``, old → new), so old run files and SPECs still read."""
        renamed: Mapping[str, str] = getattr(self.config_type, "RENAMED_FIELDS", {})
        return {renamed.get(key, key): value for key, value in values.items()}

    def config_from(self, values: Mapping[str, Any]) -> Any:
        """The scene's configuration from its saved form (JSON lists back to the tuples it holds;
        old field names renamed, :meth:`current_names`)."""
        values = self.current_names(values)
        fields = {f.name: f for f in dataclasses.fields(self.config_type)}
        unknown = sorted(set(values) - set(fields))
        if unknown:
            raise ConfigError(f"the saved {self.name} configuration has unknown entries {unknown}")
        converted = {key: tuple(value) if isinstance(value, list) and isinstance(fields[key].default, tuple) else value
                     for key, value in values.items()}
        return self.config_type(**converted)


SCENES: dict[str, SceneEntry] = {entry.name: entry for entry in (
    SceneEntry("column-collapse", "column_collapse", __name__, "ColumnCollapse", "run_column_collapse",
               "granular column collapse (dissertation ch. 2)",
               "Dry or wet granular column collapse on a rough floor."),
    SceneEntry("leg-rotation", "leg_rotation", __name__, "LegRotation", "run_leg_rotation",
               "robot leg rotated through glass beads (dissertation ch. 3)",
               "A leg held for a settling pause in a 24 x 15 cm bed of 3 mm glass beads, then rotated clockwise "
               "about its hip from -pi/4 to pi/4; lift and thrust against the leg angle."),
    SceneEntry("plate-intrusion", "plate_intrusion", __name__, "PlateIntrusion", "run_plate_intrusion",
               "horizontal plate pushed into a bed and pulled out",
               "A horizontal plate pushed down into a settled bed of glass beads at constant speed, then pulled "
               "up; vertical force against depth."),
    SceneEntry("plate-intrusion-3d", "plate_intrusion_3d", "terrasph.scenes.plate_intrusion_3d", "PlateIntrusion3D",
               "run_plate_intrusion_3d", "box plate pushed into a 3D bed (granular SPH in 3D, docs/sph3d.md)",
               "A horizontal box plate L x B pushed down at constant speed into a 3D bed of glass beads at rest in a "
               "box of fixed walls, then held; vertical force against depth, its line fit and alpha = k/(rho0 g L B) "
               "(docs/sph3d.md)."),
    SceneEntry("plate-drag", "plate_drag", "terrasph.scenes.plate_drag", "PlateDrag", "run_plate_drag",
               "a plate moved at an attack angle through a bed (resistive force theory's experiment)",
               "A plate at attack angle beta moved in direction gamma at constant speed through a settled bed of "
               "glass beads; the stress per unit depth alpha_x, alpha_z that calibrates resistive force theory "
               "(docs/rft.md)."),
    SceneEntry("leg-wheel", "leg_wheel", "terrasph.scenes.leg_wheel", "LegWheel", "run_leg_wheel",
               "hybrid leg-wheel driven through glass beads (dissertation ch. 4)",
               "One leg-wheel, free in x and z, carrying a load, paused and then driven clockwise by a motor "
               "through a bed of 3 mm glass beads (MuJoCo coupled with the SPH terrain; docs/robots.md)."),
    SceneEntry("rover", "rover", "terrasph.scenes.rover", "Rover", "run_rover",
               "planar rover with two driven leg-wheels crossing a bed",
               "The example MJCF rover (terrasph.robots.ROVER), or your own planar MJCF (--model): a chassis and "
               "two leg-wheels on driven hinges, paused and then driven clockwise across a bed of 3 mm glass "
               "beads (docs/robots.md)."),
    SceneEntry("mjcf", "mjcf", "terrasph.scenes.mjcf_scene", "MjcfScene", "run_mjcf",
               "any planar MJCF model on a bed of glass beads, any MJCF model on the 3D RFT terrain or a 3D bed",
               "A planar MuJoCo model (slides in x and z, hinges about y) on a bed of 3 mm glass beads, or any "
               "MuJoCo model (free joints, hinges about any axis) on the 3D resistive-force-theory terrain "
               "(--terrain rft) or on a 3D SPH bed of glass beads (--terrain sph3d, docs/sph3d.md): its floor is "
               "replaced by the terrain, the bodies near the floor meet it with their collision geoms, and its "
               "actuators follow --ctrl (docs/mjcf.md)."),
)}


def scene_entry(name: str) -> SceneEntry:
    """The registered scene `name`; ConfigError naming the known ones otherwise."""
    if name not in SCENES:
        raise ConfigError(f"scene {name!r} is not registered: allowed one of {', '.join(SCENES)}")
    return SCENES[name]


class CaseSummary(dict):
    """A run's summary (a plain JSON-ready dict, as the scene's ``summary()`` gives it) that also
    carries the path of the figure the run drew beside its file, as ``plot`` (None if none)."""

    plot: str | None = None


def run_case(scene: str, config: Mapping[str, Any] | Any, out: str | os.PathLike[str], *,
             progress: bool = False) -> CaseSummary:
    """Runs the registered `scene` with the configuration `config` into the run file `out`; returns
    the run's summary (with the figure's path as ``.plot``; a value the run did not define is None). `config` is the scene's fields by name
    (unknown names refused) or an instance of the scene's configuration class. The one entry point
    that ``terrasph run SCENE``, ``terrasph sweep``, its workers and the tests share; `progress`
    shows the run's progress bar (the command line's, off for sweeps)."""
    entry = scene_entry(scene)
    if not isinstance(config, entry.config_type):
        config = entry.config_from(config)
    result = entry.run(config, output=out, progress=progress)
    # a scene's result object or a robot's RobotRun; undefined values (NaN) as None: valid JSON
    summary = CaseSummary(defined_values(result.summary()))
    summary.plot = getattr(result, "plot", None)
    return summary


def scene_of_run(config_json: str) -> tuple[SceneEntry, Any]:
    """The scene and its configuration from a run file's ``config_json`` attribute."""
    config = json.loads(config_json)
    name = config.get("scene")
    if name not in SCENES:
        raise ConfigError(f"the run was not made by a registered scene (scene = {name!r}; "
                          f"known: {', '.join(SCENES)}), so it cannot be resumed by name")
    entry = SCENES[name]
    return entry, entry.config_from(config[entry.config_key])
