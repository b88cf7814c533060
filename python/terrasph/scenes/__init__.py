"""Ready-made scenes from the dissertation."""

from terrasph.scenes.column_collapse import RESOLUTIONS, ColumnCollapse, build_column_collapse, run_column_collapse

__all__ = ["RESOLUTIONS", "ColumnCollapse", "build_column_collapse", "run_column_collapse"]
