"""Ready-made scenes from the dissertation."""

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

__all__ = ["RESOLUTIONS", "ColumnCollapse", "LegRotation", "PlateIntrusion", "build_column_collapse",
           "build_leg_rotation", "build_plate_intrusion", "run_column_collapse", "run_leg_rotation",
           "run_plate_intrusion"]
