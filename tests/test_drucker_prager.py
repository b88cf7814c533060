"""Drucker–Prager elasto-plasticity with the Jaumann rate (Eq. 2.17–2.28, Appendix A), element tests
on one particle driven by a prescribed velocity gradient (``_core.constitutive_update``).

References (hand formulas in this file, tolerances stated):
* Plane-strain constants (Eq. 2.21): α = tan φ/√(9 + 12 tan²φ), k_c = 3c/√(9 + 12 tan²φ), φ = atan μ1.
* Elastic loading follows the moduli: Δσ = dt (2G D′ + K tr(D) I) for a small increment from a
  confined state (1e-12), σ_yy included (plane strain keeps it).
* Continued plastic shear stays on the yield surface, f = √J2 + α I1 − k_c = 0 to 1e-9 of k-scale.
* Flow direction: under isochoric plastic shear a non-associated flow with ψ = 0 keeps I1 (no
  dilatancy, 1e-9), an associated one changes it by −9Kα Δλ with Δλ = f*/(G + 9Kα²) (1e-9).
* Jaumann rate: a stressed particle spun rigidly keeps its invariants to first order in dt.
* Tension cut-off: a trial stress in tension returns to the apex I1 = k_c/α (dry: zero stress).
* A dilatancy angle above the friction angle is refused naming the parameter.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from terrasph import _core
from terrasph.config import ConfigError, Material

RHO0 = 2507.0
KAPPA, GAMMA = 28000.0, 7.0
K = KAPPA * GAMMA
G = 3 * K * (1 - 2 * 0.3) / (2 * (1 + 0.3))
MU1 = math.tan(math.radians(21))
ROOT = math.sqrt(9 + 12 * MU1**2)
ALPHA = MU1 / ROOT


def params(flow: str = "non_associated", dilatancy: float = 0.0, water: float = 0.0) -> _core.ModelParams2D:
    p = _core.ModelParams2D()
    p.material.model = "drucker_prager"
    p.material.reference_density = RHO0  # Table 2.1's, the references' bulk density
    p.material.plastic_flow = flow
    p.material.dilatancy_angle = dilatancy
    p.material.water_content = water
    return p


def update(p, grad, stress, dt=1e-4) -> dict:
    return _core.constitutive_update(p, np.asarray(grad, float), RHO0, dt, {"stress_state": stress})


def invariants(stress: np.ndarray) -> tuple[float, float]:
    """I1 and √J2 of a 3×3 stress."""
    i1 = float(np.trace(stress))
    s = stress - i1 / 3 * np.eye(3)
    return i1, math.sqrt(0.5 * float(np.sum(s * s)))


CONFINED = -1000.0 * np.eye(3)  # 1 kPa isotropic compression (compression negative)


def test_elastic_loading_follows_the_moduli() -> None:
    grad = np.array([[-0.2, 0.3], [0.1, 0.05]])  # a small mixed increment
    dt = 1e-4
    out = update(params(), grad, CONFINED, dt)
    l3 = np.zeros((3, 3))
    l3[:2, :2] = grad
    d = 0.5 * (l3 + l3.T)
    w = 0.5 * (l3 - l3.T)
    expected = CONFINED + dt * (w @ CONFINED - CONFINED @ w + 2 * G * (d - np.trace(d) / 3 * np.eye(3))
                                + K * np.trace(d) * np.eye(3))
    assert np.allclose(out["state"]["stress_state"], expected, rtol=1e-12, atol=1e-12 * 1000)
    assert out["state"]["stress_state"][2, 2] != CONFINED[2, 2]  # σ_yy responds (plane strain)
    assert out["pressure"] == pytest.approx(-np.trace(expected) / 3, rel=1e-12)
    assert out["wave_speed"] == pytest.approx(math.sqrt((K + 4 * G / 3) / RHO0), rel=1e-12)


@pytest.mark.parametrize("flow", ["associated", "non_associated"])
def test_plastic_shear_stays_on_the_yield_surface_and_flows_as_its_rule_says(flow) -> None:
    p = params(flow)
    shear = np.array([[0.0, 5.0], [0.0, 0.0]])  # isochoric (tr D = 0), far beyond yield after a few steps
    stress = CONFINED.copy()
    for _ in range(50):
        stress = update(p, shear, stress)["state"]["stress_state"]
    i1, root_j2 = invariants(stress)
    assert root_j2 + ALPHA * i1 == pytest.approx(0.0, abs=1e-9 * 1000)  # on the cone (c = 0)
    # one more step from a state on the surface: the trial's excess f* sets Δλ
    l3 = np.zeros((3, 3))
    l3[:2, :2] = shear
    d, w = 0.5 * (l3 + l3.T), 0.5 * (l3 - l3.T)
    trial = stress + 1e-4 * (w @ stress - stress @ w + 2 * G * d)
    trial_i1, trial_j2 = invariants(trial)
    excess = trial_j2 + ALPHA * trial_i1
    after = update(p, shear, stress)["state"]["stress_state"]
    if flow == "non_associated":  # ψ = 0: no plastic volume change, I1 of the trial is kept
        assert np.trace(after) == pytest.approx(trial_i1, rel=1e-9)
    else:
        multiplier = excess / (G + 9 * K * ALPHA**2)
        assert np.trace(after) == pytest.approx(trial_i1 - 9 * K * ALPHA * multiplier, rel=1e-9)
        assert np.trace(after) < trial_i1  # dilatancy against a fixed volume raises the confinement


def test_jaumann_update_keeps_the_invariants_to_first_order() -> None:
    p = params()
    spin = np.array([[0.0, 1.0], [-1.0, 0.0]])  # rigid rotation, D = 0
    stress0 = CONFINED + np.array([[150.0, 60.0, 0.0], [60.0, -150.0, 0.0], [0.0, 0.0, 0.0]])
    errors = []
    for dt in (2e-3, 1e-3):
        stress = stress0.copy()
        for _ in range(round(0.5 * math.pi / dt)):
            stress = update(p, spin, stress, dt)["state"]["stress_state"]
        errors.append(abs(invariants(stress)[1] - invariants(stress0)[1]) / invariants(stress0)[1])
        assert invariants(stress)[0] == pytest.approx(invariants(stress0)[0], rel=1e-12)  # I1 exact
    assert errors[1] < 4e-3
    assert errors[0] / errors[1] == pytest.approx(2.0, abs=0.2)


def test_tension_returns_to_the_apex() -> None:
    pulled = 200.0 * np.eye(3)  # isotropic tension
    dry = update(params(), np.zeros((2, 2)), pulled)
    assert np.all(dry["state"]["stress_state"] == 0.0)
    assert dry["wall_pressure_floor"] == 0.0
    wet_params = params(water=0.01)
    cohesion = Material.wet(0.01).cohesion
    k_c = 3 * cohesion / ROOT
    inside = update(wet_params, np.zeros((2, 2)), 0.1 * k_c / ALPHA * np.eye(3))  # I1 below the apex: kept
    assert np.trace(inside["state"]["stress_state"]) == pytest.approx(0.3 * k_c / ALPHA, rel=1e-12)
    wet = update(wet_params, np.zeros((2, 2)), 10 * pulled)  # I1 = 6 kPa, beyond the apex
    assert np.trace(wet["state"]["stress_state"]) == pytest.approx(k_c / ALPHA, rel=1e-12)
    assert wet["wall_pressure_floor"] == pytest.approx(-k_c / (3 * ALPHA), rel=1e-12)


def test_a_dilatancy_angle_above_the_friction_angle_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"material.dilatancy_angle"):
        Material(model="drucker_prager", dilatancy_angle=math.radians(25))
    Material(model="drucker_prager", dilatancy_angle=math.radians(20))  # below φ = 21°: accepted


def test_a_drucker_prager_bed_started_geostatic_stays_at_rest() -> None:
    """A 0.12 m × 0.05 m bed (Δx = 5 mm) in a rough box, the stress started geostatic (K0 = 1 − sin φ):
    after 0.1 s the grains move less than 1 mm/s on average [0.02 mm/s], the bottom row carries the
    lithostatic −σ_zz = ρ0 g depth within 5 % [3 %], σ_xx/σ_zz stays near K0 (within 0.15 [0.63 vs
    0.64]), and no
    grain leaks."""
    from terrasph.config import Numerics
    from terrasph.geometry import wall_layers_needed
    from terrasph.scene import Scene
    from terrasph.simulation import Simulation

    dx, width, height = 0.005, 0.12, 0.05
    scene = Scene(spacing=dx)
    scene.add_block(0.0, 0.0, width, height)
    scene.add_wall("box", [(0.0, 0.08), (0.0, 0.0), (width, 0.0), (width, 0.08)], layers=wall_layers_needed(1.3))
    material = Material(model="drucker_prager")
    sim = Simulation(scene, material, Numerics(spacing=dx))
    sim.advance(0.1)
    assert np.linalg.norm(sim.velocity, axis=1).mean() < 1e-3
    bottom = (sim.position[:, 1] < dx) & (sim.position[:, 0] > 2 * dx) & (sim.position[:, 0] < width - 2 * dx)
    lithostatic = material.reference_density * 9.81 * (height - 0.5 * dx)
    stress = sim.stress[bottom]
    assert -stress[:, 1, 1].mean() == pytest.approx(lithostatic, rel=0.05)
    assert (stress[:, 0, 0] / stress[:, 1, 1]).mean() == pytest.approx(1 - math.sin(math.atan(MU1)), abs=0.15)
    assert sim.leaked_particles == 0
