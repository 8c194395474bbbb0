"""Start a PPO/A2C policy from the analytic baseline: behaviour cloning before training.

The config key ``clone_baseline: N`` (``wheelgym`` block) makes :func:`wheelgym.agents.train.train`
run the analytic baseline (:class:`wheelgym.envs.baseline.BaselinePolicy`) on the training envs for
``N`` environment steps before PPO starts, and fit the policy's Gaussian mean to its actions by
least squares. The envs are the training ``VecEnv`` itself (in its ``VecNormalize``, whose
observation statistics the demonstration fills), so the clone sees exactly the observations
PPO will. The mean network is fitted to the baseline's actions and the value network to the
returns that followed them (without it PPO's first updates follow an untrained critic's noise
and undo the clone: DiffDrive navigate fell from about 90% to 20-70% success within 100k
steps); the log std and PPO's hyperparameters are the config's. The demonstration steps are
not counted in ``n_timesteps``; their time is in the run's wall time.

=========================== ===============================================================
knob                        value
=========================== ===============================================================
demonstration               ``N`` steps over the ``n_envs`` training envs (``N // n_envs``
                            vector steps), deterministic baseline actions in the action box
fit                         Adam, learning rate 1e-3, batches of 1024, :data:`EPOCHS` passes,
                            shuffled by a generator seeded with the config's seed
loss                        mean squared error of the Gaussian mean (after ``mean_bound``'s
                            squash where set) to the baseline's action, plus that of the
                            value estimate to the discounted return (``gamma`` of the model)
=========================== ===============================================================
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: Passes over the demonstration. Measured on DiffDrive navigate (200k steps): a mean squared
#: error of 1.3e-3 after 5 passes, 1.0e-3 after 10, 6.9e-4 after 30; 30 passes over 1M steps
#: took 310 s of a 400 s run on this 2-core machine, and PPO fine-tunes the mean anyway.
EPOCHS = 10
#: Adam's learning rate and the batch size of the fit.
LR = 1e-3
BATCH = 1024
#: Rows per forward pass when scoring a fit (bounds the memory of a 1M-row demonstration).
CHUNK = 65_536


def demonstrate(venv: Any, steps: int, gamma: float = 0.99,
                stop: Callable[[], bool] | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drive ``venv`` with the analytic baseline for ``steps`` environment steps.

    Returns the observations as ``venv`` gave them (normalised where it normalises), the
    baseline's actions and the returns that followed (the rewards ``venv`` gave, discounted by
    ``gamma`` to each row's episode end), ``(steps', obs_dim)``, ``(steps', action_dim)`` and
    ``(steps',)`` float32 with ``steps' = max(1, steps // num_envs) * num_envs``. The returns
    of the steps whose episode had not ended when the demonstration stopped are cut short
    there (their last ``1 / (1 - gamma)`` steps are within one horizon of the cut). ``stop``
    (checked before each vector step) ends the demonstration early: fewer rows. Raises
    ``ValueError`` when the envs have no baseline.
    """
    from wheelgym.envs.baseline import baseline

    try:
        policy = baseline(venv)  # it finds the env's core under SB3's wrappers
    except (TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"clone_baseline: no analytic baseline for these envs: {e}") from e
    obs = venv.reset()
    O, A, R, D = [], [], [], []
    for _ in range(max(1, steps // venv.num_envs)):
        if stop is not None and O and stop():
            break
        a = np.asarray(policy.actions(), dtype=np.float32)
        O.append(np.asarray(obs, dtype=np.float32).copy())
        A.append(a)
        obs, r, done, _ = venv.step(a)  # rows that end are reset by the env; the baseline
        # reads each row's state (and replans a car-like row at its episode's first step)
        R.append(np.asarray(r, dtype=np.float64))
        D.append(np.asarray(done, dtype=bool))
    G = returns_to_go(np.array(R), np.array(D), gamma)
    return np.concatenate(O), np.concatenate(A), G.reshape(-1).astype(np.float32)


def returns_to_go(rewards: np.ndarray, done: np.ndarray, gamma: float) -> np.ndarray:
    """``G_t = r_t + gamma (1 - done_t) G_{t+1}`` over the time axis 0 of ``(T, n_envs)``
    rewards (``G`` after the last step taken as 0)."""
    G = np.zeros(rewards.shape)
    ahead = np.zeros(rewards.shape[1:])
    for t in range(len(rewards) - 1, -1, -1):
        ahead = rewards[t] + gamma * np.where(done[t], 0.0, ahead)
        G[t] = ahead
    return G


def fit_mean(model: Any, obs: np.ndarray, actions: np.ndarray,
             returns: np.ndarray | None = None, *, epochs: int = EPOCHS,
             seed: int = 0, stop: Callable[[], bool] | None = None) -> float:
    """Fit ``model.policy``'s Gaussian mean to ``actions`` at ``obs`` (least squares), and its
    value network to ``returns`` where given (so that PPO's first advantages are the clone's,
    not an untrained critic's noise).

    Returns the mean squared action error over the last pass (over the batches it took when
    ``stop``, checked before each batch, ends the fit early; NaN before the first batch).
    """
    import torch as th

    policy = model.policy
    params = [p for n, p in policy.named_parameters() if n != "log_std"]
    opt = th.optim.Adam(params, lr=LR)
    O = th.as_tensor(obs, device=policy.device)
    A = th.as_tensor(actions, device=policy.device)
    G = None if returns is None else th.as_tensor(returns, device=policy.device)
    gen = th.Generator().manual_seed(int(seed))
    mse = float("nan")
    policy.set_training_mode(True)
    for _ in range(epochs):
        perm = th.randperm(len(O), generator=gen)
        total, seen = 0.0, 0
        for i in range(0, len(O), BATCH):
            if stop is not None and stop():
                break
            idx = perm[i:i + BATCH]
            mean = policy.get_distribution(O[idx]).distribution.mean
            loss = ((mean - A[idx]) ** 2).mean()
            total += float(loss.detach()) * len(idx)
            seen += len(idx)
            if G is not None:
                loss = loss + ((policy.predict_values(O[idx]).flatten() - G[idx]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
        if seen:
            mse = total / seen
        if stop is not None and stop():
            break
    policy.set_training_mode(False)
    return mse


def mean_error(model: Any, obs: np.ndarray, actions: np.ndarray) -> float:
    """Mean squared error of ``model.policy``'s Gaussian mean to ``actions`` at ``obs``."""
    import torch as th

    policy = model.policy
    total = 0.0
    with th.no_grad():
        for i in range(0, len(obs), CHUNK):
            o = th.as_tensor(obs[i:i + CHUNK], device=policy.device)
            a = th.as_tensor(actions[i:i + CHUNK], device=policy.device)
            total += float(((policy.get_distribution(o).distribution.mean - a) ** 2).sum())
    return total / max(np.asarray(actions).size, 1)


def value_error(model: Any, obs: np.ndarray, returns: np.ndarray) -> float:
    """Mean squared error of ``model.policy``'s value estimate to ``returns`` at ``obs``."""
    import torch as th

    policy = model.policy
    total = 0.0
    with th.no_grad():
        for i in range(0, len(obs), CHUNK):
            o = th.as_tensor(obs[i:i + CHUNK], device=policy.device)
            g = th.as_tensor(returns[i:i + CHUNK], device=policy.device)
            total += float(((policy.predict_values(o).flatten() - g) ** 2).sum())
    return total / max(len(returns), 1)


def clone_baseline(model: Any, steps: int, seed: int = 0,
                   stop: Callable[[], bool] | None = None) -> dict[str, Any]:
    """:func:`demonstrate` on ``model``'s envs, then :func:`fit_mean` (mean and value); the
    figures of the fit (``steps``, ``mse_before``, ``mse_after``, ``value_mse_before``,
    ``value_mse_after``) for the run's ``run.json``.

    ``stop`` (a Ctrl-C request, see :func:`wheelgym.agents.train.train`) ends the demonstration
    or the fit early; the figures then say ``interrupted: True`` and cover what was done.
    """
    venv = model.get_env()
    obs, actions, returns = demonstrate(venv, steps, gamma=float(model.gamma), stop=stop)
    before = mean_error(model, obs, actions)
    v_before = value_error(model, obs, returns)
    after = fit_mean(model, obs, actions, returns, seed=seed, stop=stop)
    fit: dict[str, Any] = {"steps": int(len(obs)), "mse_before": before,
                           "mse_after": None if np.isnan(after) else after,
                           "value_mse_before": v_before,
                           "value_mse_after": value_error(model, obs, returns)}
    if stop is not None and stop():
        fit["interrupted"] = True
    return fit
