"""Sand for a MuJoCo model of the user's own: :func:`attach` a compiled model and its data to a
terrain and step them with :meth:`Terrain.step` in place of ``mujoco.mj_step`` (docs/terrain.md)."""

from terrasph.terrain.interface import SPH3D_BED, SPH_BED, TERRAINS, Terrain, attach

__all__ = ["SPH3D_BED", "SPH_BED", "TERRAINS", "Terrain", "attach"]
