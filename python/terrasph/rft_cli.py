"""``terrasph rft-calibrate SWEEP``: fit an RFT coefficient table to a plate-drag sweep (docs/rft.md)."""

from __future__ import annotations

import argparse
import json
import os
from typing import Any

import numpy as np

__all__ = ["calibrate", "register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds ``rft-calibrate``."""
    p = subparsers.add_parser(
        "rft-calibrate", help="fit an RFT coefficient table to a plate-drag sweep",
        description="Least-squares fit of Li et al.'s (2013) nine Fourier coefficients and the scale zeta to the "
                    "stress per unit depth of the finished cases of a plate-drag sweep (terrasph sweep "
                    "benchmarks/studies/sweep_rft_calibration.yaml); writes the table as JSON with its units, the fit's "
                    "quality and its correlation with the generic map, for --rft-table.")
    p.add_argument("sweep", metavar="SWEEP", help="the sweep directory (its manifest.json)")
    p.add_argument("--out", required=True, help="the coefficient table to write (.json)")
    p.add_argument("--plot", default=None, metavar="PNG", help="also draw the fitted and generic maps side by side")
    p.set_defaults(handler=_cmd_calibrate)


def calibrate(sweep: str | os.PathLike[str], out: str | os.PathLike[str]) -> dict[str, Any]:
    """Fits the finished plate-drag cases of `sweep` and writes the table to `out`; returns what was
    written besides the coefficients (quality, correlation with the generic map)."""
    from terrasph import rft
    from terrasph.config import ConfigError
    from terrasph.sweeps.report import finished_cases

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
    table, quality = rft.fit_coefficients(values["attack_angle"], values["direction"], values["alpha_x"],
                                          values["alpha_z"], source=f"terrasph plate-drag sweep ({len(cases)} runs)")
    correlation = rft.map_correlation(table, rft.GENERIC)
    extra = {"fit": quality, "correlation_with_generic": correlation,
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
    from terrasph import rft

    extra = calibrate(args.sweep, args.out)
    if args.plot:
        plot_maps({"SPH": rft.load_coefficients(args.out), "generic": rft.GENERIC}, args.plot)
    print(json.dumps({"out": args.out, "plot": args.plot, **extra}, indent=2))
    return 0
