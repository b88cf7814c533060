"""``terrasph rft-calibrate SWEEP``: fit an RFT coefficient table to a plate-drag sweep (docs/rft.md)."""

from __future__ import annotations

import argparse
import json
import os
from typing import Any

import numpy as np

__all__ = ["ORDERS", "calibrate", "register"]

#: the series' orders (m, n) the calibration chooses from, by leave-one-out error (docs/rft.md)
ORDERS = ((1, 1), (1, 2), (2, 2), (2, 3), (3, 3), (3, 4), (4, 4))
MAX_ORDER_CHOICE = 4


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds ``rft-calibrate``."""
    p = subparsers.add_parser(
        "rft-calibrate", help="fit an RFT coefficient table to a plate-drag sweep",
        description="Least-squares fit of the RFT map's Fourier series (Li et al. 2013's nine coefficients are "
                    "order 1 1) and the scale zeta to the stress per unit depth of the finished cases of a plate-drag sweep (terrasph sweep "
                    "benchmarks/studies/sweep_rft_calibration.yaml); writes the table as JSON with its units, the fit's "
                    "quality and its correlation with the generic map, for --rft-table.")
    p.add_argument("sweep", metavar="SWEEP", help="the sweep directory (its manifest.json)")
    p.add_argument("--out", required=True, help="the coefficient table to write (.json)")
    p.add_argument("--order", type=int, nargs=2, default=None, metavar=("M", "N"),
                   help=f"the series' order in 2beta and gamma, each 1..{MAX_ORDER_CHOICE} (default: the order of ORDERS "
                        "whose leave-one-out error is least)")
    p.add_argument("--plot", default=None, metavar="PNG", help="also draw the fitted and generic maps side by side")
    p.set_defaults(handler=_cmd_calibrate)


def calibrate(sweep: str | os.PathLike[str], out: str | os.PathLike[str],
              order: tuple[int, int] | None = None) -> dict[str, Any]:
    """Fits the finished plate-drag cases of `sweep` with the series of `order` (default: the one of
    :data:`ORDERS` with the least leave-one-out error that the cases determine) and writes the table
    to `out`; returns what was written besides the coefficients (order, quality, correlation with
    the generic map)."""
    from terrasph.config import ConfigError
    from terrasph.sweeps.report import finished_cases
    from terrasph.terrain import rft

    if not str(out).endswith(".json"):
        raise ConfigError(f"parameter '--out' = {out!r} is invalid: allowed a .json file")
    try:
        cases = finished_cases(sweep)
    except (OSError, ValueError, KeyError) as error:
        raise ConfigError(f"'{sweep}' is not a readable sweep directory (manifest.json): {error}") from None
    cases = [c for c in cases if {"attack_angle", "direction", "alpha_x", "alpha_z"} <= set(c.get("summary", {}))]
    if not cases:
        raise ConfigError(f"sweep '{sweep}' has no finished plate-drag case")
    values = {key: np.array([c["summary"][key] for c in cases]) for key in ("attack_angle", "direction", "alpha_x",
                                                                             "alpha_z")}
    if order is not None and not all(1 <= k <= rft.MAX_ORDER for k in order):
        raise ConfigError(f"parameter '--order' = {list(order)} is invalid: allowed two integers 1..{rft.MAX_ORDER}")
    source = f"terrasph plate-drag sweep ({len(cases)} runs)"
    fits = {}
    for candidate in [tuple(order)] if order is not None else ORDERS:
        if 2 * len(cases) <= len(rft.series_names(*candidate)) and order is None:
            continue  # too few cases for this order
        try:
            fits[candidate] = rft.fit_coefficients(values["attack_angle"], values["direction"], values["alpha_x"],
                                                   values["alpha_z"], source=source, names=rft.series_names(*candidate))
        except ConfigError:
            if order is not None:
                raise
    if not fits:
        raise ConfigError(f"sweep '{sweep}' has too few finished plate-drag cases ({len(cases)}) to fit a map")
    chosen = min(fits, key=lambda k: fits[k][1]["rms_loo"])
    table, quality = fits[chosen]
    correlation = rft.map_correlation(table, rft.GENERIC)
    extra = {"order": list(chosen), "fit": quality,
             "leave_one_out_by_order": {f"{m} {n}": fit[1]["rms_loo"] for (m, n), fit in fits.items()}, "correlation_with_generic": correlation,
             "spacing": sorted({c["summary"]["spacing"] for c in cases}),
             "plate_thickness": sorted({c["summary"]["plate_thickness"] for c in cases})}
    rft.save_coefficients(table, out, **extra)
    return extra


def plot_maps(tables: dict[str, Any], path: str | os.PathLike[str]) -> None:
    """α̂_x and α̂_z of each table (divided by its ζ) over (β, γ), one row per table."""
    from matplotlib.figure import Figure

    beta, gamma = np.meshgrid(np.linspace(-np.pi / 2, np.pi / 2, 61), np.linspace(-np.pi / 2, np.pi / 2, 61))
    figure = Figure(figsize=(8.0, 3.4 * len(tables)), layout="constrained")
    axes = figure.subplots(len(tables), 2, squeeze=False)
    for row, (name, table) in zip(axes, tables.items()):
        for ax, values, label in zip(row, table.with_zeta(1.0).alpha(beta, gamma), ("α̂_x", "α̂_z")):
            mesh = ax.pcolormesh(np.degrees(beta), np.degrees(gamma), values, cmap="RdBu_r", vmin=-1, vmax=1)
            ax.set(xlabel="β (°)", ylabel="γ (°, 90 = down)", title=f"{name}: {label} (ζ = {table.zeta:.3g} N/m³)")
        figure.colorbar(mesh, ax=row.tolist())
    figure.savefig(path, dpi=120)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from terrasph.terrain import rft

    extra = calibrate(args.sweep, args.out, None if args.order is None else tuple(args.order))
    if args.plot:
        plot_maps({"SPH": rft.load_coefficients(args.out), "generic": rft.GENERIC}, args.plot)
    print(json.dumps({"out": args.out, "plot": args.plot, **extra}, indent=2))
    return 0
