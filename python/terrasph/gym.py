"""Any gymnasium MuJoCo environment on sand, unedited: ``OnSand(gymnasium.make("Walker2d-v5"), terrain="rft")``.

:class:`OnSand` attaches the environment's own model and data (``env.unwrapped.model`` and
``.data``) to a terrain (:func:`terrasph.terrain.attach`) and routes the environment's MuJoCo
stepping through it: the unwrapped environment's ``_step_mujoco_simulation`` (what gymnasium's
``MujocoEnv.do_simulation`` calls: set ``ctrl``, ``mj_step`` frame_skip times,
``mj_rnePostConstraint``) is replaced on that one instance by the same three with
:meth:`terrasph.terrain.Terrain.step` for ``mj_step``. Nothing global changes, so environments in one
process (``gymnasium.vector.SyncVectorEnv``) are independent.

Observations and rewards keep their meaning: the environment computes them from the same model
and data, with the same ``dt`` (the model's ``opt.timestep`` is left as it is); its contact forces
(``cfrc_ext``, in Ant's observation and contact cost) hold the sand's loads on the coupled bodies.
:meth:`OnSand.reset` resets the environment, then the terrain's memory (the RFT sand is flat and
keeps no state: each episode starts on an undisturbed bed). ``info["sand"]`` holds each coupled
body's load over the step (force and torque, 6 numbers as in ``xfrc_applied``: N, N·m about its
centre of mass, world axes); ``env.terrain.sinkage()`` gives each one's depth below the surface
(m) on request, ``info["sinkage"]`` after a reset (whose ``info["sand"]`` holds NaN loads, none measured yet).

gymnasium is an optional dependency: ``pip install "terrasph[gym]"``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium
import mujoco
import numpy as np

from terrasph.config import ConfigError
from terrasph.terrain import Terrain, attach

__all__ = ["OnSand"]


class OnSand(gymnasium.Wrapper, gymnasium.utils.RecordConstructorArgs):
    """`env` (a gymnasium MuJoCo environment) on `terrain` with RFT coefficient map `table`, coupling
    `bodies` (default every body with a collision geom) and the terrain's `options`
    (:func:`terrasph.terrain.attach`); module docstring. ConfigError naming the environment if it has
    no MuJoCo model or does not step through ``_step_mujoco_simulation``. Its arguments are recorded in
    the environment's spec, so ``env.spec.make()`` builds it again on sand."""

    def __init__(self, env: gymnasium.Env, terrain: str = "rft3d", table: str = "generic",
                 bodies: Sequence[str] | None = None, **options: Any) -> None:
        gymnasium.utils.RecordConstructorArgs.__init__(self, terrain=terrain, table=table, bodies=bodies, **options)
        gymnasium.Wrapper.__init__(self, env)
        base: Any = env.unwrapped  # a MujocoEnv, checked below
        model, data = getattr(base, "model", None), getattr(base, "data", None)
        name = env.spec.id if env.spec is not None else type(base).__name__
        if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
            raise ConfigError(f"environment '{name}' has no MuJoCo model (env.unwrapped.model and .data): OnSand "
                              "puts gymnasium's MuJoCo environments on sand")
        if not callable(getattr(base, "_step_mujoco_simulation", None)):
            raise ConfigError(f"environment '{name}' does not step MuJoCo through _step_mujoco_simulation "
                              "(gymnasium's MujocoEnv): OnSand cannot route its steps through the sand")
        self.terrain: Terrain = attach(model, data, terrain, table, bodies, **options)
        base._step_mujoco_simulation = self._step_on_sand  # this instance only

    def _step_on_sand(self, ctrl: np.ndarray, n_frames: int) -> None:
        """MujocoEnv._step_mujoco_simulation with the sand's step for mj_step."""
        terrain = self.terrain
        terrain.data.ctrl[:] = ctrl
        terrain.step(n_frames)
        mujoco.mj_rnePostConstraint(terrain.model, terrain.data)  # cfrc_ext, cacc: as MujocoEnv does

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """The environment's reset, then the terrain's (an undisturbed bed); ``info`` as the
        environment's with each coupled body's sinkage at the start and ``"sand"`` as a step's
        (NaN loads: none measured before the first step), so that a loop reads the same keys after
        a reset as after a step."""
        observation, info = self.env.reset(seed=seed, options=options)
        self.terrain.reset()
        return observation, {**info, "sand": self.terrain.loads(), "sinkage": self.terrain.sinkage()}

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        """The environment's step on the sand; ``info`` as the environment's with the sand's loads
        (module docstring)."""
        observation, reward, terminated, truncated, info = self.env.step(action)
        return observation, reward, terminated, truncated, {**info, "sand": self.terrain.loads()}
