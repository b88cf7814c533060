"""A driven wheel on soft soil with a simple slip-sinkage law: sequences with a known answer.

Until the robot scenes produce data, the surrogate is trained on this small dynamical system.
State: forward speed v [m/s] and sinkage z [m]; input: commanded wheel speed ω(t) [rad/s];
fixed run parameters: load W [N], soil stiffness k [-] and traction coefficient μ [-].

    slip s      = 1 - v/(Rω)        if v < Rω                      (Eq. 4.8)
                = Rω/v - 1          otherwise
    traction    F_t = μ W (1 - exp(-s/s0))                          (Janosi-Hanamoto-like)
    resistance  F_r = W c_r z / R                                   (compaction, grows with z)
    speed       m_e (W/g) dv/dt = F_t - F_r     (m_e: effective inertia factor)
    sinkage     dz/dt = (z_eq - z)/τ_z,   z_eq = z_ref sqrt(W/(k W_ref)) (1 + a_s max(s, 0))

Integrated with classical RK4 at a fine internal step and sampled at ``dt``. The map from
(ω history, W, k, μ) to (slip, sinkage) is deterministic, so a sequence model can learn it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from terrasph.surrogate.dataset import Run, write_run

G = 9.81


@dataclass(frozen=True)
class WheelParams:
    """Constants of the synthetic wheel–soil law (SI units)."""

    radius: float = 0.04  # R [m], the dissertation's 2R = 8 cm leg-wheel
    s0: float = 0.15  # traction shape slip [-]
    c_r: float = 1.0  # compaction resistance coefficient [-]
    z_ref: float = 0.005  # static sinkage at W_ref, k = 1 [m]
    w_ref: float = 4.9  # reference load [N] (dissertation: 4.9 N)
    a_s: float = 1.5  # slip-sinkage amplification [-]
    tau_z: float = 0.3  # sinkage relaxation time [s]
    inertia: float = 200.0  # effective mass / (W/g): drivetrain inertia and towed mass [-]


def slip(v: np.ndarray | float, omega: np.ndarray | float, radius: float) -> np.ndarray:
    """Slip of Eq. 4.8 for forward speed ``v`` and wheel speed ``omega`` (Rω > 0 required)."""
    v_a = np.asarray(v, dtype=float)
    rw = radius * np.asarray(omega, dtype=float)
    if np.any(rw <= 0):
        raise ValueError("slip needs R*omega > 0 (omega must be positive)")
    return np.where(v_a < rw, 1.0 - v_a / rw, rw / np.maximum(v_a, 1e-300) - 1.0)


def _rhs(v: float, z: float, omega: float, load: float, soil_k: float, mu: float,
         p: WheelParams) -> tuple[float, float]:
    """Time derivatives (dv/dt, dz/dt) of the wheel state (scalar code for speed)."""
    rw = p.radius * omega
    s = 1.0 - v / rw if v < rw else rw / v - 1.0  # Eq. 4.8
    f_t = mu * load * (1.0 - math.exp(-s / p.s0))
    f_r = load * p.c_r * z / p.radius
    z_eq = p.z_ref * math.sqrt(load / (soil_k * p.w_ref)) * (1.0 + p.a_s * max(s, 0.0))
    return (f_t - f_r) * G / (p.inertia * load), (z_eq - z) / p.tau_z


def omega_profile(rng: np.random.Generator, time: np.ndarray, omega_min: float = 0.5,
                  omega_max: float = 3.0, tau: float = 0.2) -> np.ndarray:
    """Random commanded wheel speed: levels held 0.5-2 s, smoothed by a first-order lag τ."""
    levels = np.empty_like(time)
    t_next, level = 0.0, rng.uniform(omega_min, omega_max)
    for k, t in enumerate(time):
        if t >= t_next:
            level = rng.uniform(omega_min, omega_max)
            t_next = t + rng.uniform(0.5, 2.0)
        levels[k] = level
    out = np.empty_like(time)
    out[0] = omega_min
    for k in range(1, time.size):
        a = 1.0 - np.exp(-(time[k] - time[k - 1]) / tau)
        out[k] = out[k - 1] + a * (levels[k] - out[k - 1])
    return out


def simulate_wheel(omega: np.ndarray, dt: float, load: float, soil_k: float, mu: float,
                   params: WheelParams = WheelParams(), substeps: int = 4) -> dict[str, np.ndarray]:
    """Integrate the wheel for the sampled command ``omega`` (held constant over each interval).

    Returns series ``vx`` [m/s], ``slip`` [-] and ``sinkage`` [m], sampled like ``omega``.
    """
    if dt <= 0:
        raise ValueError(f"dt must be > 0, got {dt}")
    for name, value in (("load", load), ("soil_k", soil_k), ("mu", mu)):
        if not value > 0:
            raise ValueError(f"{name} must be > 0, got {value}")
    n = omega.size
    if np.any(~(np.asarray(omega) > 0)):
        raise ValueError("omega must be positive (slip of Eq. 4.8 needs R*omega > 0)")
    v, z = 0.0, params.z_ref * math.sqrt(load / (soil_k * params.w_ref))
    v_out, z_out = np.empty(n), np.empty(n)
    h = dt / substeps
    for k in range(n):
        v_out[k], z_out[k] = v, z
        if k == n - 1:
            break
        w = float(omega[k])
        for _ in range(substeps):  # classical RK4
            a1, b1 = _rhs(v, z, w, load, soil_k, mu, params)
            a2, b2 = _rhs(v + 0.5 * h * a1, z + 0.5 * h * b1, w, load, soil_k, mu, params)
            a3, b3 = _rhs(v + 0.5 * h * a2, z + 0.5 * h * b2, w, load, soil_k, mu, params)
            a4, b4 = _rhs(v + h * a3, z + h * b3, w, load, soil_k, mu, params)
            v = max(v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4), 0.0)
            z = z + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
    return {"vx": v_out, "slip": slip(v_out, omega, params.radius), "sinkage": z_out}


def make_run(seed: int, duration: float = 6.0, dt: float = 0.02,
             params: WheelParams = WheelParams(), name: str | None = None) -> Run:
    """One synthetic run with random ω(t), load W ∈ [2, 8] N, k ∈ [0.5, 2], μ ∈ [0.4, 0.8]."""
    if duration <= 0:
        raise ValueError(f"duration must be > 0, got {duration}")
    rng = np.random.default_rng(seed)
    time = np.arange(round(duration / dt) + 1) * dt
    omega = omega_profile(rng, time)
    run_params = {
        "load": float(rng.uniform(2.0, 8.0)),
        "soil_k": float(rng.uniform(0.5, 2.0)),
        "mu": float(rng.uniform(0.4, 0.8)),
    }
    series = simulate_wheel(omega, dt, run_params["load"], run_params["soil_k"],
                            run_params["mu"], params)
    series["omega_cmd"] = omega
    return Run(
        name=name or f"wheel_{seed}", time=time, series=series, params=run_params,
        units={"omega_cmd": "rad/s", "vx": "m/s", "slip": "1", "sinkage": "m"},
    )


def make_dataset(out_dir: str | Path, n_runs: int = 40, seed: int = 0, duration: float = 6.0,
                 dt: float = 0.02) -> list[Path]:
    """Write ``n_runs`` synthetic runs (``wheel_XXXX.h5``) into ``out_dir``; returns the paths."""
    if n_runs < 1:
        raise ValueError(f"n_runs must be >= 1, got {n_runs}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    config = {"scene": "synthetic_wheel", "source": "terrasph.surrogate.synthetic",
              "wheel": asdict(WheelParams()), "seed": seed, "duration": duration, "dt": dt}
    for r in range(n_runs):
        run = make_run(seed * 100003 + r, duration, dt, name=f"wheel_{r:04d}")
        paths.append(write_run(out / f"{run.name}.h5", run, body="wheel",
                               config={**config, "run_params": run.params}))
    return paths


#: Default selection for the synthetic wheel: inputs and targets.
DEFAULT_FEATURES = ("omega_cmd", "load", "soil_k", "mu")
DEFAULT_TARGETS = ("slip", "sinkage")
