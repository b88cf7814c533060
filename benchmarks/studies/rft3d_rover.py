"""The four-wheeled rover of ``terrasph/robots/models/rover4.xml`` on the 3D RFT terrain (docs/rft.md,
"3D RFT"): dropped on the sand, then all four wheels commanded a constant spin; prints the travel,
the chassis height, the wheels' spin and the simulated seconds per CPU second on one core.

    OMP_NUM_THREADS=1 python benchmarks/studies/rft3d_rover.py [--time-step 0.001] [--element-length 0.013] \\
        [--drop 0.5] [--t-end 2.5] [--omega 3.0] [--rft-table generic|TABLE.json]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import terrasph
from terrasph.terrain.rft3d_coupling import RFT3D_TIME_STEP, RFT3DCoupling, rft_robot

ROVER = Path(terrasph.__file__).parent / "robots" / "models" / "rover4.xml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--time-step", type=float, default=RFT3D_TIME_STEP, help="MuJoCo's step (s)")
    parser.add_argument("--element-length", type=float, default=None,
                        help="surface elements about this long (m); default: terrasph.terrain.rft3d.ELEMENT_FRACTION")
    parser.add_argument("--drop", type=float, default=0.5, help="time with the wheels held still (s)")
    parser.add_argument("--t-end", type=float, default=2.5, help="end of the run (s)")
    parser.add_argument("--omega", type=float, default=3.0, help="the wheels' commanded spin after the drop (rad/s)")
    parser.add_argument("--rft-table", default="generic")
    args = parser.parse_args()
    robot = rft_robot(ROVER, element_length=args.element_length)
    coupled = RFT3DCoupling(robot, args.rft_table, time_step=args.time_step)
    data = robot.data

    def control(stepper: RFT3DCoupling) -> None:
        data.ctrl[:] = 0.0 if stepper.time < args.drop else args.omega

    cpu = time.process_time()
    coupled.advance(args.drop, control=control)
    x0 = float(data.qpos[0])
    coupled.advance(args.t_end, control=control)
    cpu = time.process_time() - cpu
    print(f"time step {args.time_step * 1e3:g} ms, element length {args.element_length or 'default'}: "
          f"travel {100 * (data.qpos[0] - x0):.2f} cm in {args.t_end - args.drop:g} s driven, chassis origin "
          f"{1e3 * data.qpos[2]:.2f} mm above the surface, wheel spins {np.round(data.qvel[6:], 2).tolist()} rad/s, "
          f"{coupled.time / cpu:.3f} simulated s per CPU s")


if __name__ == "__main__":
    main()
