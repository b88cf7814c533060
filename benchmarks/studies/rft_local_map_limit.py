"""Can any local RFT map give both the plates and the legs? (docs/rft.md, "Carried grains")

The RFT load of a leg is linear in the map's coefficients, so one least-squares system can hold the
plate-drag points and the SPH legs' load series together, the legs' rows weighted by `--weights`
(0: the plates alone). The plate points are the calibrated table's values on the calibration's 12 × 13
grid (its measured points are not stored; the table's rms residual is 2.8 × 10³ N/m³). For each
weight it prints the plates' misfit, each leg's peak lift and thrust over the SPH's with the legs
fitted, and with each leg left out of the fit (the test of a map: the leg it has not seen):

    python benchmarks/studies/rft_local_map_limit.py RUNS_DIR [--weights 0 1 3 10]

RUNS_DIR holds the SPH sweeps LEG.h5 of `terrasph run leg-rotation --leg LEG --omega 0.2 --bed-depth 0.08
--settle-time 0.3 --out LEG.h5` for the five legs. Run with the carried grains off (the map alone).
"""

from __future__ import annotations

import argparse
import math
import pathlib

import numpy as np
from terrasph.io import read_run
from terrasph.scenes.leg_rotation import LEGS, LegRotation
from terrasph.terrain import rft

TABLE = pathlib.Path(__file__).resolve().parents[1] / "results" / "rft_glass_beads_sph.json"


def leg_basis(leg: str, angles: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """(samples, 2, terms): each term's (F_x, F_z) on the leg at each angle, for a unit coefficient."""
    config = LegRotation(leg=leg, terrain="rft")
    elements = rft.SurfaceElements.from_shape(config.shape(), width=config.width)
    out = np.zeros((len(angles), 2, len(names)))
    for k, name in enumerate(names):
        unit = rft.RFTCoefficients({name: 1.0}, zeta=1.0, density=0.0)
        for i, angle in enumerate(angles):
            out[i, :, k] = rft.body_load(elements, angle, (0.0, config.hip_height), np.zeros(2), config.omega,
                                         0.0, unit).force
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=pathlib.Path)
    parser.add_argument("--weights", type=float, nargs="+", default=[0.0, 1.0, 3.0, 10.0])
    args = parser.parse_args()
    table = rft.load_coefficients(TABLE)
    names = table.names
    beta, gamma = (g.ravel() for g in np.meshgrid(np.radians(np.arange(-82.5, 90, 15.0)), np.radians(np.linspace(-90, 90, 13))))
    alpha_x, alpha_z = table.alpha(beta, gamma)
    plate_x, plate_z = rft.fourier_basis(beta, gamma, names)
    plates, measured = np.vstack([plate_x, plate_z]), np.concatenate([alpha_x, alpha_z])
    legs = {}
    for leg in LEGS:
        series = read_run(args.runs / f"{leg}.h5").series["bodies/leg"]
        turning = series["time"] > 0.3 + 1e-9
        angles, force = series["angle"][turning][::4], series["force"][turning][::4]
        legs[leg] = (force, leg_basis(leg, angles, names))

    def fit(weight: float, fitted: list[str]) -> np.ndarray:
        rows, values = [plates / 1e5], [measured / 1e5]  # plates in 10⁵ N/m³, legs in N per √sample
        for leg in fitted:
            force, basis = legs[leg]
            scale = weight / math.sqrt(len(force))
            rows.append(scale * basis.reshape(-1, len(names)))
            values.append(scale * force.reshape(-1))
        return np.linalg.lstsq(np.vstack(rows), np.concatenate(values), rcond=None)[0]

    def ratios(coefficients: np.ndarray, leg: str) -> str:
        force, basis = legs[leg]
        predicted = basis @ coefficients
        return f"{predicted[:, 1].max() / force[:, 1].max():.2f} / {predicted[:, 0].max() / force[:, 0].max():.2f}"

    print("peak lift / thrust, RFT over SPH; plates' misfit in N/m³ (rms of the plate stresses "
          f"{math.sqrt(np.mean(measured ** 2)):.0f})")
    for weight in args.weights:
        together = fit(weight, list(legs))
        misfit = math.sqrt(np.mean((plates @ together - measured) ** 2))
        print(f"weight {weight:g}: plates' misfit {misfit:.0f}")
        for leg in legs:
            print(f"  {leg}: all five fitted {ratios(together, leg)}; "
                  f"left out {ratios(fit(weight, [other for other in legs if other != leg]), leg)}")


if __name__ == "__main__":
    main()
