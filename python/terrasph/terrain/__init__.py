"""The terrains and their steppers (docs/architecture.md, "The terrain wing"). Sand for a MuJoCo
model of the user's own: :func:`attach` a compiled model and its data to a terrain and step them
with :meth:`Terrain.step` in place of ``mujoco.mj_step`` (docs/terrain.md).

The interface's names are imported on first use, so that the RFT laws (``terrasph.terrain.rft``,
``rft3d``), which the plain SPH scenes use, load without MuJoCo and the couplings."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from terrasph.terrain.interface import SPH3D_BED, SPH_BED, TERRAINS, Terrain, attach, couple

__all__ = ["SPH3D_BED", "SPH_BED", "TERRAINS", "Terrain", "attach", "couple"]


def __getattr__(name: str) -> Any:
    """One of :data:`__all__`, from terrasph.terrain.interface (imported then)."""
    if name in __all__:
        from terrasph.terrain import interface

        return getattr(interface, name)
    raise AttributeError(f"module 'terrasph.terrain' has no attribute {name!r}")
