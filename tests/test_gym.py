"""terrasph.gym.OnSand: gymnasium's MuJoCo environments on sand without editing them. gymnasium's own
checker passes, environments in one vector environment step as each does alone (nothing shared in
the process), a reset starts on an undisturbed bed (the same trajectory as a fresh environment's),
the sand's loads reach the environment's contact forces, and an environment without a MuJoCo model
is refused by name."""

from __future__ import annotations

import numpy as np
import pytest
from terrasph.config import ConfigError

gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("gymnasium.envs.mujoco")
from gymnasium.utils.env_checker import check_env
from terrasph.gym import OnSand


def _rollout(env: gymnasium.Env, seed: int, actions: np.ndarray) -> list[np.ndarray]:
    """Observations from reset(seed) under `actions`, up to the episode's end."""
    observation, _ = env.reset(seed=seed)
    trace = [observation]
    for action in actions:
        observation, _, terminated, truncated, _ = env.step(action)
        trace.append(observation)
        if terminated or truncated:
            break
    return trace


@pytest.mark.parametrize(("env_id", "terrain"), [("Ant-v5", "rft3d"), ("Walker2d-v5", "rft")])
def test_gymnasiums_checker_passes_on_sand(env_id: str, terrain: str) -> None:
    env = OnSand(gymnasium.make(env_id), terrain=terrain)
    check_env(env, skip_render_check=True)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert set(info["sand"]) == set(env.terrain.bodies)
    assert env.unwrapped.dt == gymnasium.make(env_id).unwrapped.dt  # the reward's velocities keep their meaning


def test_a_reset_starts_on_an_undisturbed_bed() -> None:
    """After an episode of random actions, reset(seed) and the same actions give the trajectory of a
    fresh environment: nothing of the first episode is kept."""
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (30, 6))
    used = OnSand(gymnasium.make("Walker2d-v5"), terrain="rft")
    _rollout(used, 11, actions)
    again = _rollout(used, 5, actions)
    fresh = _rollout(OnSand(gymnasium.make("Walker2d-v5"), terrain="rft"), 5, actions)
    assert len(again) == len(fresh) and all(np.array_equal(a, b) for a, b in zip(again, fresh))


def test_a_loop_reads_the_same_sand_keys_after_a_reset_as_after_a_step() -> None:
    """A loop that resets on termination and reads info["sand"] afterwards (the tutorial's) finds it
    after a reset too: every coupled body, no load measured yet (NaN) until the first step, then a
    finite load per body."""
    env = OnSand(gymnasium.make("Walker2d-v5"), terrain="rft")
    _, info = env.reset(seed=0)
    assert set(info["sand"]) == set(env.terrain.bodies)
    assert all(np.isnan(load).all() for load in info["sand"].values())
    _, _, _, _, info = env.step(np.zeros(env.action_space.shape))
    assert set(info["sand"]) == set(env.terrain.bodies)
    assert all(np.isfinite(load).all() for load in info["sand"].values())


@pytest.mark.slow
def test_a_reset_puts_back_the_undisturbed_sph_bed() -> None:
    """On the SPH bed, whose grains remember the last episode's footprints, a reset puts back the bed
    built at the start: the same trajectory as a fresh environment's."""
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (15, 6))
    used = OnSand(gymnasium.make("Walker2d-v5"), terrain="sph")
    _rollout(used, 11, actions)
    again = _rollout(used, 5, actions)
    fresh = _rollout(OnSand(gymnasium.make("Walker2d-v5"), terrain="sph"), 5, actions)
    assert len(again) == len(fresh) and all(np.array_equal(a, b) for a, b in zip(again, fresh))
    assert used.terrain.leaked_grains == 0


def test_two_environments_in_one_vector_environment_step_as_each_alone() -> None:
    rng = np.random.default_rng(4)
    actions = rng.uniform(-1.0, 1.0, (25, 2, 6))
    seeds = [1, 2]
    vector = gymnasium.vector.SyncVectorEnv([lambda: OnSand(gymnasium.make("Walker2d-v5"), terrain="rft")] * 2)
    observations, _ = vector.reset(seed=seeds)
    together = [observations]
    for action in actions:
        observations, *_ = vector.step(action)
        together.append(observations)
    for k in range(2):
        alone = _rollout(OnSand(gymnasium.make("Walker2d-v5"), terrain="rft"), seeds[k], actions[:, k])
        # up to the end of its first episode (the vector environment then resets it)
        assert all(np.array_equal(a, b[k]) for a, b in zip(alone, together))


def test_the_ants_contact_forces_are_the_sands_loads() -> None:
    """Ant's observation ends with its bodies' external contact forces (cfrc_ext), which on sand
    hold the sand's loads: once the ant rests, their vertical forces carry its weight."""
    env = OnSand(gymnasium.make("Ant-v5", include_cfrc_ext_in_observation=True), terrain="rft3d")
    env.reset(seed=0)
    for _ in range(40):  # 2 s with the actuators idle
        env.step(np.zeros(8))
    model, data = env.unwrapped.model, env.unwrapped.data
    weight = float(model.body_subtreemass[0]) * 9.81
    assert data.cfrc_ext[1:, 5].sum() == pytest.approx(weight, rel=0.02)


@pytest.mark.slow
@pytest.mark.parametrize(("env_id", "terrain"), [("Ant-v5", "rft3d"), ("Walker2d-v5", "rft")])
def test_a_thousand_random_steps_on_sand(env_id: str, terrain: str) -> None:
    env = OnSand(gymnasium.make(env_id), terrain=terrain)
    env.action_space.seed(0)
    env.reset(seed=0)
    for _ in range(1000):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert np.isfinite(observation).all() and np.isfinite(reward)
        assert all(np.isfinite(load).all() for load in info["sand"].values())
        if terminated or truncated:
            env.reset()


def test_an_environment_without_a_mujoco_model_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="environment 'CartPole-v1' has no MuJoCo model"):
        OnSand(gymnasium.make("CartPole-v1"))


@pytest.mark.slow
def test_the_ant_on_the_3d_sph_bed() -> None:
    """Ant-v5 on the 3D SPH bed (attach's default, Δx = 5 cm): dropped from its reset pose with the
    actuators idle, over 0.5–1 s after landing its contact forces (cfrc_ext, in its observation)
    carry its weight within 2 % (Newton's first law; measured 0.6 % off while its legs still spread
    slowly); ``info["sand"]`` holds a finite load per coupled body; no grain leaks; after a reset,
    random actions run."""
    env = OnSand(gymnasium.make("Ant-v5", include_cfrc_ext_in_observation=True), terrain="sph3d")
    _, info = env.reset(seed=0)
    assert set(info["sinkage"]) == set(env.terrain.bodies)
    model, data = env.unwrapped.model, env.unwrapped.data
    weight = float(model.body_subtreemass[0]) * 9.81
    lift = []
    for k in range(20):  # 1 s, Ant-v5's 0.05 s per step
        _, _, terminated, _, info = env.step(np.zeros(8))
        assert not terminated
        assert list(info["sand"]) == list(env.terrain.bodies)
        assert all(np.isfinite(load).all() for load in info["sand"].values())
        if k >= 10:
            lift.append(data.cfrc_ext[1:, 5].sum())
    assert np.mean(lift) == pytest.approx(weight, rel=0.02)
    env.reset(seed=1)
    env.action_space.seed(1)
    for _ in range(5):
        env.step(env.action_space.sample())
    assert env.terrain.leaked_grains == 0


@pytest.mark.slow
def test_a_reset_puts_back_the_undisturbed_3d_sph_bed() -> None:
    """On the 3D SPH bed, a reset puts back the bed built at the start: after an episode, the same
    trajectory as a fresh environment's."""
    actions = np.random.default_rng(4).uniform(-1.0, 1.0, (8, 8))
    used = OnSand(gymnasium.make("Ant-v5"), terrain="sph3d")
    _rollout(used, 11, actions)
    again = _rollout(used, 5, actions)
    fresh = _rollout(OnSand(gymnasium.make("Ant-v5"), terrain="sph3d"), 5, actions)
    assert len(again) == len(fresh) and all(np.array_equal(a, b) for a, b in zip(again, fresh))
    assert used.terrain.leaked_grains == 0
