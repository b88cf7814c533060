"""terrasph's 3D RFT terrain as a MuJoCo engine plugin, ``terrasph.rft`` (docs/mujoco_plugin.md).

The plugin is a shared library, ``libterrasph_mujoco_plugin.so`` in this directory (built with the
package: cpp/plugin/rft_plugin.cpp). A model whose MJCF names it,

.. code-block:: xml

    <extension>
      <plugin plugin="terrasph.rft">
        <instance name="sand">
          <config key="table" value="generic"/>
          <config key="surface" value="0"/>
        </instance>
      </plugin>
    </extension>

stands on sand in any MuJoCo program once the library is loaded: :func:`load` here (an installed
terrasph also declares it as MuJoCo's entry point ``mujoco.plugins``, which ``import mujoco`` calls),
or ``mj_loadPluginLibrary(path)`` in C/C++ (:func:`library_path` says where it is). The keys of
``<config>`` are listed in docs/mujoco_plugin.md. The load is a
passive force, which the plugin makes implicit with terrasph's backward-Euler step under MuJoCo's
Euler, implicit and implicitfast integrators (explicit under RK4); the docs page gives the steps at
which it is accurate against terrasph's implicit RFT stepper, measured.
"""

from __future__ import annotations

import pathlib

import mujoco
import numpy as np

__all__ = ["LIBRARY_NAME", "PLUGIN_NAME", "body_wrenches", "coupled_bodies", "library_path", "load"]

#: the registered name MJCF files give in ``<plugin plugin="...">``
PLUGIN_NAME = "terrasph.rft"
#: the shared library's file name, in this package directory
LIBRARY_NAME = "libterrasph_mujoco_plugin.so"


def library_path() -> pathlib.Path:
    """The plugin library's path; FileNotFoundError if the package was installed without it."""
    path = pathlib.Path(__file__).with_name(LIBRARY_NAME)
    if not path.is_file():
        raise FileNotFoundError(f"the MuJoCo plugin library {path} is missing: build the package with its "
                                "CMake (target terrasph_mujoco_plugin)")
    return path


def load() -> pathlib.Path:
    """Registers ``terrasph.rft`` with the process's MuJoCo (idempotent: the dynamic loader opens a
    library once, and its registration runs then); returns the library's path."""
    path = library_path()
    mujoco.mj_loadPluginLibrary(str(path))
    return path


def _instance(model: mujoco.MjModel, instance: int | str) -> int:
    """The plugin instance's id from its id or name."""
    if isinstance(instance, str):
        found = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, instance)
        if found < 0:
            raise KeyError(f"the model has no plugin instance named {instance!r}")
        return found
    return int(instance)


def coupled_bodies(model: mujoco.MjModel, instance: int | str = 0) -> list[int]:
    """The bodies the instance loads (the plugin's rule): those whose MJCF names it
    (``<body><plugin instance="sand"/></body>``), else every body not welded to the world that has a
    collision geom (contype or conaffinity set)."""
    k = _instance(model, instance)
    named = [b for b in range(1, model.nbody) if model.body_plugin[b] == k]
    if named:
        return named
    collides = [bool(model.geom_contype[g] or model.geom_conaffinity[g]) for g in range(model.ngeom)]
    return [b for b in range(1, model.nbody) if model.body_weldid[b] != 0
            and any(collides[g] for g in range(model.body_geomadr[b], model.body_geomadr[b] + model.body_geomnum[b]))]


def body_wrenches(model: mujoco.MjModel, data: mujoco.MjData, instance: int | str = 0) -> dict[str, np.ndarray]:
    """Each coupled body's load at MuJoCo's last evaluation of passive forces, by body name: (6,) force
    (N) and torque (N·m) about its centre of mass, world frame (the instance's plugin state)."""
    k = _instance(model, instance)
    start = int(model.plugin_stateadr[k])
    state = np.asarray(data.plugin_state[start:start + int(model.plugin_statenum[k])]).reshape(-1, 6)
    return {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"#{b}": state[i].copy()
            for i, b in enumerate(coupled_bodies(model, k))}
