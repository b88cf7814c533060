"""Ready-made scenes from the dissertation."""

from terrasph.scenes.column_collapse import ColumnCollapse, RESOLUTIONS, build_column_collapse, run_column_collapse

__all__ = ["ColumnCollapse", "RESOLUTIONS", "build_column_collapse", "run_column_collapse"]
