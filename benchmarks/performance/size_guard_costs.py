"""Size-guard constants (terrasph.size_guard): peak RSS per particle and wall time per particle-step
of a plate-intrusion bed of known size on one thread.

    python benchmarks/performance/size_guard_costs.py SPACING BED_WIDTH BED_DEPTH
"""
import resource
import sys
import time

from terrasph import _core
from terrasph.scenes.plate_intrusion import PlateIntrusion, build_plate_intrusion
from terrasph.simulation import Simulation

_core.set_num_threads(1)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
dx = float(sys.argv[1])
width, depth = float(sys.argv[2]), float(sys.argv[3])
cfg = PlateIntrusion(spacing=dx, bed_width=width, bed_depth=depth, plate_length=width / 4, max_depth=0.01)
scene, material, numerics = build_plate_intrusion(cfg)[:3]
sim = Simulation(scene, material, numerics)
n = len(sim.position)
sim.advance(1e-12, max_steps=2)
t0 = time.perf_counter()
steps = sim.advance(1.0, max_steps=20)
t1 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(f"dx {dx} granular {n} peak_rss_MiB {peak / 1024:.0f} base_MiB {base / 1024:.0f} "
      f"bytes_per_granular {(peak - base) * 1024 / n:.0f} ns_per_particle_step {(t1 - t0) / steps / n * 1e9:.0f} "
      f"dt {sim.core.last_dt:.3e}")
