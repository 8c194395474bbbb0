"""``gym.make`` in a fresh process that never ran ``import wheelgym`` (Gymnasium 1.x reads no
plugin entry points): the ``wheelgym:`` module prefix, and subprocess workers that start fresh."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from wheelgym.registration import ENV_CLASSES, env_id

ROOT = Path(__file__).resolve().parents[1]


def _fresh(code: str, tmp_path: Path, timeout: float = 300) -> str:
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_env_id_names_the_valid_robots():
    assert env_id("ThreeWheel") == "wheelgym/ThreeWheel-v0"
    with pytest.raises(ValueError, match=rf"unknown robot 'Tricycle'.*{list(ENV_CLASSES)[0]}"):
        env_id("Tricycle")


def test_module_prefix_makes_and_steps_without_import(tmp_path):
    out = _fresh(
        "import sys\n"
        "import gymnasium as gym\n"
        "from gymnasium.error import NamespaceNotFound\n"
        "try:\n"
        "    gym.make('wheelgym/ThreeWheel-v0')\n"
        "except NamespaceNotFound:\n"
        "    print('plain id: NamespaceNotFound')\n"  # Gymnasium 1.x: no entry points read
        "assert 'wheelgym' not in sys.modules\n"
        "env = gym.make('wheelgym:wheelgym/ThreeWheel-v0')\n"
        "obs, _ = env.reset(seed=0)\n"
        "obs, r, term, trunc, info = env.step(env.action_space.sample())\n"
        "assert env.observation_space.contains(obs) and env.spec.max_episode_steps == 500\n"
        "vec = gym.make_vec('wheelgym:wheelgym/Unicycle-v0', num_envs=3)\n"
        "obs, _ = vec.reset(seed=0)\n"
        "obs, *_ = vec.step(vec.action_space.sample())\n"
        "print('made', env.spec.id, type(vec).__name__, obs.shape)\n",
        tmp_path)
    assert "plain id: NamespaceNotFound" in out
    assert "made wheelgym/ThreeWheel-v0 UnicycleVectorEnv (3," in out


def test_spawned_async_workers_register_through_the_prefix(tmp_path):
    """Gymnasium's ``AsyncVectorEnv`` with ``spawn`` workers: each worker is a fresh
    interpreter that makes its env from the id."""
    out = _fresh(
        "import gymnasium as gym\n"
        "if __name__ == '__main__':\n"
        "    vec = gym.make_vec('wheelgym:wheelgym/Unicycle-v0', num_envs=2,\n"
        "                       vectorization_mode='async', vector_kwargs={'context': 'spawn'})\n"
        "    obs, _ = vec.reset(seed=0)\n"
        "    obs, *_ = vec.step(vec.action_space.sample())\n"
        "    vec.close()\n"
        "    print('workers', obs.shape)\n",
        tmp_path)
    assert "workers (2," in out


@pytest.mark.slow
def test_spawned_sb3_workers_register_through_the_prefix(tmp_path):
    """SB3's ``make_vec_env`` with ``SubprocVecEnv`` and ``spawn`` workers (each imports torch:
    slow): the worker's ``gym.make(id)`` imports wheelgym through the prefix."""
    out = _fresh(
        "from stable_baselines3.common.env_util import make_vec_env\n"
        "from stable_baselines3.common.vec_env import SubprocVecEnv\n"
        "if __name__ == '__main__':\n"
        "    venv = make_vec_env('wheelgym:wheelgym/Unicycle-v0', n_envs=2, seed=0,\n"
        "                        vec_env_cls=SubprocVecEnv,\n"
        "                        vec_env_kwargs={'start_method': 'spawn'})\n"
        "    obs = venv.reset()\n"
        "    obs, rew, done, info = venv.step([venv.action_space.sample() for _ in range(2)])\n"
        "    venv.close()\n"
        "    print('workers', obs.shape)\n",
        tmp_path)
    assert "workers (2," in out


def _made_warnings(**kwargs) -> list[str]:
    """The warnings of one ``gym.make`` under wheelgym's own filters only (not pytest's)."""
    import warnings

    import gymnasium as gym

    from wheelgym.registration import register_envs

    with warnings.catch_warnings(record=True) as caught:
        warnings.resetwarnings()
        register_envs()  # (idempotent) its filter
        gym.make("wheelgym/DiffDrive-v0", **kwargs).close()
    return [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]


def test_v0_is_out_of_date_only_for_navigate():
    """-v1 changes navigate alone: goal and track -v0 make without Gymnasium's "out of date"
    notice, navigate -v0 says why and names its -v1 id."""
    assert not [m for m in _made_warnings(task="goal") if "out of date" in m]
    assert not [m for m in _made_warnings(task="track") if "out of date" in m]
    nav = [m for m in _made_warnings(task="navigate") if "out of date" in m]
    assert len(nav) == 1 and "wheelgym/DiffDrive-v1" in nav[0] and "early" in nav[0]
