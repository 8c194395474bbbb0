"""Start a PPO/A2C policy from the analytic baseline: behaviour cloning before training.

The config key ``clone_baseline: N`` (``wheelgym`` block) makes :func:`wheelgym.agents.train.train`
run the analytic baseline (:class:`wheelgym.envs.baseline.BaselinePolicy`) on the training envs for
``N`` environment steps before PPO starts, and fit the policy's Gaussian mean to its actions by
least squares. The envs are the training ``VecEnv`` itself (in its ``VecNormalize``, whose
observation statistics the demonstration fills), so the clone sees exactly the observations
PPO will. Only the mean network is fitted: the log std, the value network and PPO's
hyperparameters are the config's. The demonstration steps are not counted in ``n_timesteps``;
their time is in the run's wall time.

=========================== ===============================================================
knob                        value
=========================== ===============================================================
demonstration               ``N`` steps over the ``n_envs`` training envs (``N // n_envs``
                            vector steps), deterministic baseline actions in the action box
fit                         Adam, learning rate 1e-3, batches of 1024, :data:`EPOCHS` passes,
                            shuffled by a generator seeded with the config's seed
loss                        mean squared error of the Gaussian mean (after ``mean_bound``'s
                            squash where set) to the baseline's action
=========================== ===============================================================
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Passes over the demonstration. Measured on DiffDrive navigate (200k steps): a mean squared
#: error of 1.3e-3 after 5 passes, 1.0e-3 after 10, 6.9e-4 after 30; 30 passes over 1M steps
#: took 310 s of a 400 s run on this 2-core machine, and PPO fine-tunes the mean anyway.
EPOCHS = 10
#: Adam's learning rate and the batch size of the fit.
LR = 1e-3
BATCH = 1024


def _core_env(venv: Any) -> Any:
    """The wheelgym env under SB3's wrappers (``VecNormalize``, ``VecMonitor``, adapter)."""
    e = venv
    while hasattr(e, "venv"):
        e = e.venv
    return e


def demonstrate(venv: Any, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Drive ``venv`` with the analytic baseline for ``steps`` environment steps.

    Returns the observations as ``venv`` gave them (normalised where it normalises) and the
    baseline's actions, ``(steps', obs_dim)`` and ``(steps', action_dim)`` float32 with
    ``steps' = max(1, steps // num_envs) * num_envs``. Raises ``ValueError`` when the envs
    have no baseline.
    """
    from wheelgym.envs.baseline import baseline

    env = _core_env(venv)
    try:
        policy = baseline(env)
    except (TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"clone_baseline: no analytic baseline for these envs: {e}") from e
    obs = venv.reset()
    O, A = [], []
    for _ in range(max(1, steps // venv.num_envs)):
        a = np.asarray(policy.actions(), dtype=np.float32)
        O.append(np.asarray(obs, dtype=np.float32).copy())
        A.append(a)
        obs, _, _, _ = venv.step(a)  # rows that end are reset by the env; the baseline
        # reads each row's state (and replans a car-like row at its episode's first step)
    return np.concatenate(O), np.concatenate(A)


def fit_mean(model: Any, obs: np.ndarray, actions: np.ndarray, *, epochs: int = EPOCHS,
             seed: int = 0) -> float:
    """Fit ``model.policy``'s Gaussian mean to ``actions`` at ``obs`` (least squares).

    Returns the mean squared error over the last pass.
    """
    import torch as th

    policy = model.policy
    params = [p for n, p in policy.named_parameters() if n != "log_std"]
    opt = th.optim.Adam(params, lr=LR)
    O = th.as_tensor(obs, device=policy.device)
    A = th.as_tensor(actions, device=policy.device)
    gen = th.Generator().manual_seed(int(seed))
    mse = float("nan")
    policy.set_training_mode(True)
    for _ in range(epochs):
        perm = th.randperm(len(O), generator=gen)
        total = 0.0
        for i in range(0, len(O), BATCH):
            idx = perm[i:i + BATCH]
            mean = policy.get_distribution(O[idx]).distribution.mean
            loss = ((mean - A[idx]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
        mse = total / len(O)
    policy.set_training_mode(False)
    return mse


def mean_error(model: Any, obs: np.ndarray, actions: np.ndarray) -> float:
    """Mean squared error of ``model.policy``'s Gaussian mean to ``actions`` at ``obs``."""
    import torch as th

    policy = model.policy
    with th.no_grad():
        mean = policy.get_distribution(th.as_tensor(obs, device=policy.device)).distribution.mean
        return float(((mean - th.as_tensor(actions, device=policy.device)) ** 2).mean())


def clone_baseline(model: Any, steps: int, seed: int = 0) -> dict[str, float]:
    """:func:`demonstrate` on ``model``'s envs, then :func:`fit_mean`; the figures of the fit
    (``steps``, ``mse_before``, ``mse_after``) for the run's ``run.json``."""
    venv = model.get_env()
    obs, actions = demonstrate(venv, steps)
    before = mean_error(model, obs, actions)
    after = fit_mean(model, obs, actions, seed=seed)
    return {"steps": int(len(obs)), "mse_before": before, "mse_after": after}
