"""Size-guard constants of a 3D scene (terrasph.size_guard): peak RSS per particle (grains and walls)
and wall time per particle-step of a 3D plate-intrusion bed of known size on one thread.

    python benchmarks/performance/size_guard_costs_3d.py SPACING [BED_LENGTH BED_BREADTH BED_DEPTH]
"""
import resource
import sys
import time

from terrasph import _core
from terrasph.scenes.plate_intrusion_3d import PlateIntrusion3D, build_plate_intrusion_3d

_core.set_num_threads(1)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
dx = float(sys.argv[1])
size = dict(zip(("bed_length", "bed_breadth", "bed_depth"), map(float, sys.argv[2:5])))
sim = build_plate_intrusion_3d(PlateIntrusion3D(spacing=dx, **size))
n = len(sim.core.mass) + len(sim.core.wall_position)
sim.advance(1e-12, max_steps=2)
t0 = time.perf_counter()
steps = sim.advance(1.0, max_steps=20)
t1 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(f"dx {dx} granular {len(sim.core.mass)} walls {len(sim.core.wall_position)} peak_rss_MiB {peak / 1024:.0f} "
      f"base_MiB {base / 1024:.0f} bytes_per_particle {(peak - base) * 1024 / n:.0f} "
      f"ns_per_particle_step {(t1 - t0) / steps / n * 1e9:.0f} dt {sim.core.last_dt:.3e}")
