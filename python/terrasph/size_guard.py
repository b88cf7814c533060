"""The size guard: before a scene is built, estimate its particles, memory and run time, refuse
what does not fit in memory and ask for ``--yes`` above :data:`CONFIRM_HOURS` hours.

The estimate comes from the scene's geometry (its :meth:`footprint`: granular area, wall length,
spacing, end time, material, numerics), not from building it: a spacing a hundred times too fine
is refused within a second, where the build alone would take minutes and the memory of a machine.

* Particles: N = A/Δx² + L·layers/Δx (the lattice of the grains, the wall rows); in 3D
  N = V/Δx³ + S·layers/Δx² (the grains' volume, the walls' area).
* Memory: N · :data:`BYTES_PER_PARTICLE` (3D: :data:`BYTES_PER_PARTICLE_3D`) + the interpreter's own.
* Steps: t_end / Δt with Δt = cfl · h · √f / c0 (the core's stable step without the flow's own
  speed, Eq. 2.46's artificial sound speed c0, mass scaling f), so a lower bound on the steps: the
  core's step divides by max(c0, the model's wave speed) + |v|, which only makes it smaller.
* Time: N · steps · :data:`SECONDS_PER_PARTICLE_STEP` / threads (perfect scaling: a lower bound).

The constants are measured (docs/cli.md, "The size guard", gives the command and figures).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, Protocol

from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed

__all__ = ["BYTES_PER_PARTICLE", "BYTES_PER_PARTICLE_3D", "CONFIRM_HOURS", "SECONDS_PER_PARTICLE_STEP", "Footprint", "SizeEstimate",
           "available_memory", "check_size", "estimate"]

#: peak resident memory per particle (grains and walls), measured: 626–646 B at 80 k–320 k grains
#: (plate-intrusion bed, one thread; docs/cli.md)
BYTES_PER_PARTICLE = 650.0
#: the same in 3D, per grain and wall particle: 1 237–1 309 B at 87 k–156 k particles (a 3D plate-intrusion bed,
#: one thread; python benchmarks/performance/size_guard_costs_3d.py 0.0025, … 0.002)
BYTES_PER_PARTICLE_3D = 1300.0
#: the interpreter with terrasph, numpy, h5py and MuJoCo loaded, before any particle (measured 46 MiB)
BASE_BYTES = 200e6
#: wall time of one particle-step on one thread, measured 0.87–1.4 µs (the same beds, shared machine)
SECONDS_PER_PARTICLE_STEP = 1.0e-6
#: above this estimated run time the command line asks for ``--yes``
CONFIRM_HOURS = 24.0


@dataclass(frozen=True)
class Footprint:
    """What a scene's size depends on, from its configuration alone."""

    spacing: float  #: Δx (m)
    granular_area: float  #: area the grains fill (m²); 0 in 3D
    wall_length: float  #: length of the walls, each `layers` rows of particles (m); 0 in 3D
    end_time: float  #: simulated time (s)
    material: Material
    numerics: Numerics
    granular_volume: float = 0.0  #: a 3D scene: the volume the grains fill (m³)
    wall_area: float = 0.0  #: a 3D scene: the area of its walls, each `layers` sheets of particles (m²)

    @property
    def three_d(self) -> bool:
        """Whether the footprint is a 3D scene's."""
        return self.granular_volume > 0


class Sized(Protocol):
    """A scene configuration the guard can judge."""

    def footprint(self) -> Footprint: ...


@dataclass(frozen=True)
class SizeEstimate:
    """A run's estimated size."""

    particles: int
    memory_bytes: float
    steps: float
    hours: float  #: at the thread count the estimate was made for

    def describe(self) -> str:
        """One phrase: particles, memory, steps and time."""
        return (f"about {self.particles:,} particles, {self.memory_bytes / 2**30:.2g} GiB, {self.steps:.3g} steps, "
                f"{self.hours:.3g} h")


def estimate(footprint: Footprint, threads: int = 1) -> SizeEstimate:
    """The particles, memory, steps and wall time of a run of `footprint` on `threads` threads."""
    from terrasph import _core

    dx = footprint.spacing
    layers = wall_layers_needed(footprint.numerics.h_factor)
    particles = (footprint.granular_area / dx**2 + footprint.wall_length * layers / dx
                 + footprint.granular_volume / dx**3 + footprint.wall_area * layers / dx**2)
    params = _core.ModelParams2D()
    params.material = footprint.material.to_core()
    params.numerics = footprint.numerics.to_core()
    sound_speed = params.artificial_sound_speed  # c0, Eq. 2.46
    numerics = footprint.numerics
    step = numerics.cfl * numerics.h_factor * dx * math.sqrt(numerics.mass_scaling) / sound_speed
    steps = footprint.end_time / step
    seconds = particles * steps * SECONDS_PER_PARTICLE_STEP / max(1, threads)
    per_particle = BYTES_PER_PARTICLE_3D if footprint.three_d else BYTES_PER_PARTICLE
    return SizeEstimate(int(particles), BASE_BYTES + particles * per_particle, steps, seconds / 3600.0)


def _meminfo_available() -> float | None:
    """Bytes of physical memory available now (/proc/meminfo's MemAvailable), else None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        return None
    return None


def _address_space_left() -> float | None:
    """Bytes the process may still map under its address-space and data limits (RLIMIT_AS,
    RLIMIT_DATA soft limits, e.g. ``ulimit -v``) beyond what it maps now (/proc/self/status VmSize),
    else None (no limit)."""
    try:
        import resource
    except ImportError:  # not a POSIX system
        return None
    soft = [resource.getrlimit(kind)[0] for kind in (resource.RLIMIT_AS, resource.RLIMIT_DATA)]
    limits = [float(limit) for limit in soft if limit != resource.RLIM_INFINITY]
    if not limits:
        return None
    mapped = 0.0
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    mapped = float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return max(0.0, min(limits) - mapped)


def _cgroup_memory_left() -> float | None:
    """Bytes the process's control group may still use (cgroup v2 memory.max − memory.current, or
    v1 memory.limit_in_bytes − memory.usage_in_bytes), else None (no limit, or no cgroup)."""
    try:
        with open("/proc/self/cgroup", encoding="ascii") as cgroups:
            lines = cgroups.read().splitlines()
    except OSError:
        return None
    for line in lines:
        _, controllers, path = line.split(":", 2)
        if controllers == "":  # v2
            folder, names = f"/sys/fs/cgroup{path}", ("memory.max", "memory.current")
        elif "memory" in controllers.split(","):  # v1
            folder, names = f"/sys/fs/cgroup/memory{path}", ("memory.limit_in_bytes", "memory.usage_in_bytes")
        else:
            continue
        try:
            with open(os.path.join(folder, names[0]), encoding="ascii") as limit_file:
                limit = limit_file.read().strip()
            with open(os.path.join(folder, names[1]), encoding="ascii") as usage_file:
                usage = float(usage_file.read().strip())
        except (OSError, ValueError):
            continue
        if limit != "max" and float(limit) < 2.0**62:  # v1 writes "no limit" as a huge number
            return max(0.0, float(limit) - usage)
    return None


def available_memory() -> tuple[float, str] | None:
    """The bytes of memory this process can still use and what bounds them: the least of the
    physical memory available now (MemAvailable), the process's address-space and data limits
    (RLIMIT_AS, RLIMIT_DATA) and its control group's memory limit; None if none is known."""
    bounds = [(value, name) for value, name in ((_meminfo_available(), "available"),
                                                 (_address_space_left(),
                                                  "left under the process's address-space limit"),
                                                 (_cgroup_memory_left(), "left under the control group's limit"))
              if value is not None]
    return min(bounds) if bounds else None


def check_size(config: Sized | Any, *, confirmed: bool, threads: int | None = None) -> SizeEstimate | None:
    """Refuses (ConfigError, one line) a run of `config` that would not fit in the memory available
    now, or that would take more than CONFIRM_HOURS hours unless `confirmed`; returns the estimate
    (None for a configuration without a footprint)."""
    if not hasattr(config, "footprint"):
        return None
    footprint = config.footprint()
    size = estimate(footprint, threads or os.cpu_count() or 1)
    memory = available_memory()
    spacing = f"spacing {footprint.spacing:g} m"
    if memory is not None and size.memory_bytes > memory[0]:
        raise ConfigError(f"{spacing} is too fine for this process: {size.describe()}, but only "
                          f"{memory[0] / 2**30:.2g} GiB of memory is {memory[1]}; use a coarser spacing or a "
                          "smaller bed")
    if size.hours > CONFIRM_HOURS and not confirmed:
        raise ConfigError(f"{spacing}: {size.describe()} (over {CONFIRM_HOURS:g} h at the measured "
                          f"{SECONDS_PER_PARTICLE_STEP * 1e6:g} us per particle-step); add --yes to run it anyway")
    return size
