"""Start a PPO/A2C policy from the analytic baseline (behaviour cloning before training), and
take the internal force out of a trained one (after): the work of the pipeline's ``imitate``
stage (:mod:`wheelgym.agents.pipeline`).

``{stage: imitate, teacher: baseline, steps: N}`` before the ``rl`` stage makes
:func:`wheelgym.agents.train.train` run the analytic baseline
(:class:`wheelgym.envs.baseline.BaselinePolicy`) on the training envs for ``N`` environment
steps, and fit the policy's Gaussian mean to its actions by least squares
(:func:`clone_baseline`). The envs are the training ``VecEnv`` itself (in its ``VecNormalize``,
whose observation statistics the demonstration fills), so the clone sees exactly the
observations PPO will. The mean network is fitted to the baseline's actions and the value
network to the returns that followed them, so that PPO's first updates follow the clone's
advantages rather than an untrained critic's noise; the log std and PPO's hyperparameters are
the config's. The demonstration steps are not counted in ``n_timesteps``; their time is in the
run's wall time.

With ``rounds: K`` the ``N`` steps come in ``K`` rounds (DAgger, Ross, Gordon & Bagnell
2011): after the first, the clone as fitted so far drives and the baseline labels the states
it reaches, and each round refits on all rows so far. A clone trained only on the baseline's
states drifts into states the baseline never visits, where it has no label.

=========================== ===============================================================
knob                        value
=========================== ===============================================================
demonstration               ``N`` steps over the ``n_envs`` training envs (``N // n_envs``
                            vector steps), deterministic baseline actions in the action box;
                            in ``K`` rounds of ``N // K`` with ``rounds``
fit                         Adam at ``lr`` (default :data:`LR`), batches of :data:`BATCH`,
                            ``epochs`` passes (default :data:`EPOCHS`; per round, over all
                            rows so far), shuffled by a generator seeded with the config's
                            seed (plus the round's index)
loss                        mean squared error of the Gaussian mean (after
                            ``policy_kwargs.mean_bound``'s squash where set) to the baseline's
                            action, plus that of the value estimate to the discounted return
                            (``gamma`` of the model); with ``internal_force: w`` (torque mode,
                            robots with an internal force) plus ``w`` times the squared
                            internal force of the action error (:func:`internal_force_rows`)
=========================== ===============================================================

An action error in the null space of the motors (TW-6, paper (36)) moves nothing but is
internal force; the plain least squares weighs it like an error that moves the robot, so a
clone of the load distribution, which puts almost nothing there, fights itself by as much as
it misses. ``internal_force`` weighs that part of the error more.

``{stage: imitate, teacher: self_without_internal_force, steps: N}`` after the ``rl`` stage
works the other way round (:func:`distill_internal_force`): the trained policy is its own
teacher, its actions less their internal force (:func:`without_internal_force`, the same
generalized force ``J^T tau``) the labels, the states those the policy reaches (``N`` steps in
``rounds`` DAgger rounds). It takes out the internal force that PPO's reward leaves in a
torque-mode policy while keeping its motion. The measurements behind the defaults below are in
docs/topics/research-log-configs.md (section "The imitate stage's defaults").
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

#: Passes over the demonstration per round (docs/topics/research-log-configs.md, "The imitate
#: stage's defaults").
EPOCHS = 10
#: Adam's learning rate and the batch size of the fit.
LR = 1e-3
BATCH = 1024
#: Adam's learning rate of :func:`distill_internal_force`'s fits, and its default rounds and
#: internal-force weight (docs/topics/research-log-configs.md, "The imitate stage's defaults").
DISTILL_LR = 1e-4
DISTILL_ROUNDS = 6
DISTILL_WEIGHT = 1000.0
#: Rows per forward pass when scoring a fit (bounds the memory of a 1M-row demonstration).
CHUNK = 65_536


class Demonstration(NamedTuple):
    """Rows of :func:`demonstrate`: ``(rows, obs_dim)``, ``(rows, action_dim)`` and ``(rows,)``
    float32, the episodes that ended during it and how many of them succeeded, and (asked
    for with ``internal_force=True``) each row's :func:`internal_force_rows`,
    ``(rows, m - 3, m)`` float32."""

    obs: np.ndarray
    actions: np.ndarray
    returns: np.ndarray
    episodes: int
    successes: int
    force_rows: np.ndarray | None = None


def internal_force_rows(core: Any) -> np.ndarray:
    """Per env row, the matrix ``W (m - 3, m)`` with ``|W a| = |P tau| / |tau_max|`` for a
    normalised torque action ``a`` (``tau = a * tau_max`` of the row, N·m): ``W = N^T
    diag(tau_max) / |tau_max|``, ``N`` the orthonormal basis of null(J^T) at the row's steering
    angles (TW-6, paper (36); :func:`wheelgym.control.distribution.null_space_basis`), each
    row's own parameters. ``|tau_max|`` is the nominal robot's, as in the reward's
    internal-force term (:func:`wheelgym.tasks.tasks.internal_force_scale`), so ``|W e|`` is
    that term's measure of an action error ``e``. Shape ``(N, m - 3, m)``.

    ``ValueError`` for a robot without an internal force or an action mode other than
    ``torque``.
    """
    from wheelgym.tasks.tasks import internal_force_scale

    N, tau_max = _null_space(core, "clone_internal_force")
    return _force_rows(N, tau_max, internal_force_scale(core))


def _force_rows(N: np.ndarray, tau_max: np.ndarray, scale: float) -> np.ndarray:
    """:func:`internal_force_rows` from :func:`_null_space`'s figures and ``|tau_max|``."""
    return (np.swapaxes(N, 1, 2) * tau_max[:, None, :] / scale).astype(np.float32)


def without_internal_force(core: Any, actions: np.ndarray) -> np.ndarray:
    """Normalised torque actions ``(N, m)`` of ``core``'s rows less their internal force.

    ``tau = a * tau_max`` (N·m) loses its null-space part: ``tau - N N^T tau`` (TW-6, paper
    (36); ``N`` as in :func:`internal_force_rows`), the minimum-norm torque with the same
    generalized force ``J^T tau``, so the same motion. Back in normalised units and clipped to
    the action box ``[-1, 1]`` (a clipped row keeps some internal force). float32.
    """
    return _less_internal_force(*_null_space(core, "distill_internal_force"), actions)


def _less_internal_force(N: np.ndarray, tau_max: np.ndarray, actions: Any) -> np.ndarray:
    """:func:`without_internal_force` from :func:`_null_space`'s figures."""
    tau = np.asarray(actions, dtype=np.float64).reshape(len(N), -1) * tau_max
    tau -= np.einsum("nmk,nk->nm", N, np.einsum("nmk,nm->nk", N, tau))
    return np.clip(tau / tau_max, -1.0, 1.0).astype(np.float32)


def check_distill_envs(venv: Any) -> None:
    """``ValueError`` saying why :func:`distill_internal_force` cannot run on ``venv`` (checked
    before training, not after it): no wheelgym core under its wrappers (it needs the native
    vector env, ``vec_env: native``), or a robot without an internal force or an action mode
    other than ``torque``."""
    from wheelgym.envs.baseline import baseline

    try:
        core = baseline(venv).core
    except (TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"distill_internal_force: needs wheelgym's native vector env "
                         f"(vec_env: native): {e}") from e
    _check_internal_force(core, "distill_internal_force")


def _check_internal_force(core: Any, what: str) -> None:
    """``ValueError`` (naming ``what``) for a robot without an internal force or an action mode
    other than ``torque``."""
    spec = core.spec
    if not spec.has_internal_force or core.action_mode != "torque":
        raise ValueError(f"{what}: needs a robot with an internal force in "
                         f"action mode 'torque', got {spec.name} in {core.action_mode!r}")


def _null_space(core: Any, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``core``: the orthonormal basis ``N (m, m - 3)`` of null(J^T) at its steering
    angles (TW-6) and the row's torque limits ``tau_max (m,)`` (N·m);
    :func:`_check_internal_force` first."""
    from wheelgym.control.distribution import null_space_basis

    _check_internal_force(core, what)
    models: dict[int, Any] = {}
    rows = core.params_rows
    J = np.empty((core.num, core.HI.shape[1], 3))
    for p in {id(p): p for p in rows}.values():
        mdl = core.model if p is core.base_params else type(core.model)(p)
        models[id(p)] = mdl
    for i, p in enumerate(rows):
        mdl = models[id(p)]
        J[i] = mdl.jacobian(core.X[i, 6:9])  # psi_1..3 (the model's state layout, TW-1)
    return null_space_basis(J), np.asarray(core.HI, dtype=np.float64)  # HI: each row's tau_max


def demonstrate(venv: Any, steps: int, gamma: float = 0.99,
                stop: Callable[[], bool] | None = None,
                actor: Callable[[np.ndarray], np.ndarray] | None = None,
                internal_force: bool = False, planner: str | None = None,
                model_kind: str = "nominal",
                teacher_kwargs: dict[str, Any] | None = None) -> Demonstration:
    """Label ``steps`` environment steps of ``venv`` with the analytic baseline's actions.

    The baseline drives, or ``actor`` (observations -> actions, e.g. the clone's deterministic
    ``predict``) drives and the baseline's actions at the states it reaches are the labels
    (DAgger). Returns the observations as ``venv`` gave them (normalised where it normalises),
    the baseline's actions and the returns that followed (the rewards ``venv`` gave, discounted
    by ``gamma`` to each row's episode end) over ``max(1, steps // num_envs) * num_envs``
    rows. The returns of the steps whose episode had not ended when the demonstration stopped
    are cut short there (their last ``1 / (1 - gamma)`` steps are within one horizon of the
    cut). ``stop`` (checked before each vector step) ends the demonstration early: fewer rows.
    ``internal_force`` records each row's :func:`internal_force_rows` too (read before the
    step, like the label). Raises ``ValueError`` when the envs have no baseline (or, with
    ``internal_force``, no internal force). ``planner``: the planning baseline's planner
    (``wheelgym.baseline(env, planner=...)``, navigate only) labels instead of the reactive one;
    ``model_kind`` (``"nominal"`` or ``"true"``): the parameters the baseline computes with;
    ``teacher_kwargs``: more keywords of :func:`wheelgym.baseline` (``v_cap``, ``w_cap``,
    ``twist_gains``).
    """
    from wheelgym.envs.baseline import baseline

    try:
        # it finds the env's core under SB3's wrappers
        policy = baseline(venv, planner=planner, model=model_kind, **(teacher_kwargs or {}))
    except (TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"clone_baseline: no analytic baseline for these envs: {e}") from e
    if internal_force:
        _check_internal_force(policy.core, "clone_internal_force")  # before the first step
    obs = venv.reset()
    O, A, R, D, F = [], [], [], [], []
    episodes = successes = 0
    for _ in range(max(1, steps // venv.num_envs)):
        if stop is not None and O and stop():
            break
        a = np.asarray(policy.actions(), dtype=np.float32)  # the label, read before the step
        O.append(np.asarray(obs, dtype=np.float32).copy())
        A.append(a)
        if internal_force:
            F.append(internal_force_rows(policy.core))
        act = a if actor is None else np.asarray(actor(obs), dtype=np.float32)
        obs, r, done, infos = venv.step(act)  # rows that end are reset by the env; the
        # baseline reads each row's state (and replans a car-like row at its episode's first
        # step)
        R.append(np.asarray(r, dtype=np.float64))
        D.append(np.asarray(done, dtype=bool))
        for i in np.flatnonzero(D[-1]):
            episodes += 1
            successes += bool(infos[i].get("is_success", False))
    G = returns_to_go(np.array(R), np.array(D), gamma)
    return Demonstration(np.concatenate(O), np.concatenate(A),
                         G.reshape(-1).astype(np.float32), episodes, successes,
                         np.concatenate(F) if internal_force else None)


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
             seed: int = 0, stop: Callable[[], bool] | None = None,
             force_rows: np.ndarray | None = None, force_weight: float = 0.0,
             lr: float = LR) -> float:
    """Fit ``model.policy``'s Gaussian mean to ``actions`` at ``obs`` (least squares), and its
    value network to ``returns`` where given (so that PPO's first advantages are the clone's,
    not an untrained critic's noise). With ``force_rows`` (:func:`internal_force_rows` of each
    row) the action loss is ``(|e|^2 + force_weight |W e|^2) / m`` per row, ``e`` the error of
    the mean: the internal force of the error weighs ``force_weight`` more. ``lr``: Adam's
    learning rate.

    Returns the mean squared action error over the last pass (over the batches it took when
    ``stop``, checked before each batch, ends the fit early; NaN before the first batch).
    """
    import torch as th

    policy = model.policy
    params = [p for n, p in policy.named_parameters() if n != "log_std"]
    opt = th.optim.Adam(params, lr=lr)
    O = th.as_tensor(obs, device=policy.device)
    A = th.as_tensor(actions, device=policy.device)
    G = None if returns is None else th.as_tensor(returns, device=policy.device)
    Wf = None if force_rows is None or not force_weight else \
        th.as_tensor(force_rows, device=policy.device)
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
            err = mean - A[idx]
            loss = (err ** 2).mean()
            total += float(loss.detach()) * len(idx)
            seen += len(idx)
            if Wf is not None:  # |W e|^2 per row over the m action columns, as the MSE
                wf = th.einsum("bkm,bm->bk", Wf[idx], err)
                loss = loss + force_weight * (wf ** 2).sum(dim=1).mean() / err.shape[1]
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


def force_error(model: Any, obs: np.ndarray, actions: np.ndarray,
                force_rows: np.ndarray) -> float:
    """Mean over rows of ``|W e|`` (:func:`internal_force_rows`), ``e`` the error of
    ``model.policy``'s Gaussian mean to ``actions``: the internal force of the error as a share
    of ``|tau_max|``, the reward term's measure."""
    import torch as th

    policy = model.policy
    total = 0.0
    with th.no_grad():
        for i in range(0, len(obs), CHUNK):
            o = th.as_tensor(obs[i:i + CHUNK], device=policy.device)
            e = policy.get_distribution(o).distribution.mean - th.as_tensor(
                actions[i:i + CHUNK], device=policy.device)
            w = th.as_tensor(force_rows[i:i + CHUNK], device=policy.device)
            total += float(th.linalg.vector_norm(th.einsum("bkm,bm->bk", w, e), dim=1).sum())
    return total / max(len(obs), 1)


def clone_baseline(model: Any, steps: int, seed: int = 0,
                   stop: Callable[[], bool] | None = None, rounds: int = 1,
                   epochs: int | None = None,
                   internal_force: float | None = None, lr: float = LR,
                   planner: str | None = None, model_kind: str = "nominal",
                   teacher_kwargs: dict[str, Any] | None = None) -> dict[str, Any]:
    """Fit ``model``'s mean and value network to the baseline on ``model``'s envs.

    ``rounds`` splits the ``steps`` labelled rows: the baseline drives the first
    ``steps // rounds``; each later round the clone as fitted so far drives (its deterministic
    action) and the baseline labels the states it reaches (DAgger: the states a clone drifts
    into are where it needs labels), and :func:`fit_mean` refits on all rows so far, ``epochs``
    passes each (default :data:`EPOCHS`). Returns
    the figures for the run's ``run.json``: ``steps`` (rows), the mean squared action error on
    the baseline's rows before the fit (``mse_before``) and over the last pass of the last fit
    (``mse_after``), the value error on the baseline's rows before and on all rows after
    (``value_mse_before``, ``value_mse_after``) and, with ``rounds > 1``, per round who drove,
    its episodes, the share of them that succeeded, and (from the second) the clone's action
    error on the new rows before it refits (``rounds``). ``internal_force`` (the config's
    ``clone_internal_force``) weighs the internal force of the action error in the fit
    (:func:`fit_mean`); the figures then add ``internal_force_weight`` and the mean
    :func:`force_error` before and after (``force_error_before``, ``force_error_after``).
    ``lr``: Adam's learning rate of the fits (default :data:`LR`). ``planner``: the planning
    baseline (``wheelgym.baseline(env, planner=planner)``, navigate only) is the teacher;
    ``model_kind``: the parameters the analytic baseline computes with (``"nominal"`` or
    ``"true"``, :data:`wheelgym.envs.baseline.BASELINE_MODELS`); ``teacher_kwargs``: more
    keywords of :func:`wheelgym.baseline` (the stage's ``teacher_kwargs``).

    ``stop`` (a Ctrl-C request, see :func:`wheelgym.agents.train.train`) ends the demonstration
    or the fit early; the figures then say ``interrupted: True`` and cover what was done.
    """
    venv = model.get_env()
    gamma = float(model.gamma)
    per = max(1, steps // rounds)
    forces = bool(internal_force)
    demo = demonstrate(venv, per, gamma=gamma, stop=stop, internal_force=forces,
                       planner=planner, model_kind=model_kind, teacher_kwargs=teacher_kwargs)
    obs, actions, returns, rows = demo.obs, demo.actions, demo.returns, demo.force_rows
    driver = "planner" if planner else "baseline" + ("" if model_kind == "nominal" else " (true)")
    log = [{"driver": driver, **_episodes(demo)}]
    before = mean_error(model, obs, actions)
    f_before = force_error(model, obs, actions, rows) if forces else None
    v_before = value_error(model, obs, returns)
    after = float("nan")
    for k in range(rounds):
        if k:  # all rows so far, and the new ones
            demo = demonstrate(venv, per, gamma=gamma, stop=stop, internal_force=forces,
                               actor=lambda o: model.predict(o, deterministic=True)[0],
                               planner=planner, model_kind=model_kind,
                               teacher_kwargs=teacher_kwargs)
            log.append({"driver": "clone", **_episodes(demo),
                        "mse_on_its_states": mean_error(model, demo.obs, demo.actions)})
            obs = np.concatenate([obs, demo.obs])
            actions = np.concatenate([actions, demo.actions])
            returns = np.concatenate([returns, demo.returns])
            if forces:
                rows = np.concatenate([rows, demo.force_rows])
        if stop is not None and stop():
            break
        after = fit_mean(model, obs, actions, returns, epochs=epochs or EPOCHS, seed=seed + k,
                         stop=stop, force_rows=rows,
                         force_weight=float(internal_force or 0.0), lr=lr)
    fit: dict[str, Any] = {"steps": int(len(obs)), "epochs": epochs or EPOCHS,
                           "mse_before": before,
                           "mse_after": None if np.isnan(after) else after,
                           "value_mse_before": v_before,
                           "value_mse_after": value_error(model, obs, returns)}
    if forces:
        fit.update(internal_force_weight=float(internal_force),
                   force_error_before=f_before,
                   force_error_after=force_error(model, obs, actions, rows))
    if rounds > 1:
        fit["rounds"] = log
    if stop is not None and stop():
        fit["interrupted"] = True
    return fit


def distill_internal_force(model: Any, steps: int, rounds: int = DISTILL_ROUNDS,
                           weight: float = DISTILL_WEIGHT, epochs: int | None = None,
                           seed: int = 0, lr: float = DISTILL_LR,
                           stop: Callable[[], bool] | None = None) -> dict[str, Any]:
    """Take the internal force out of a trained policy's Gaussian mean, keeping its motion.

    The teacher is the policy as trained (a frozen copy), its deterministic action less its
    internal force (:func:`without_internal_force`: the same ``J^T tau``, no null-space part).
    ``steps`` rows in ``rounds`` rounds: the policy as fitted so far drives ``model``'s training
    envs (its deterministic action), the teacher labels each state, and :func:`fit_mean`
    refits the mean on all rows so far (``epochs`` passes, default :data:`EPOCHS`; Adam at
    ``lr``, default :data:`DISTILL_LR`; internal-force weight ``weight``). The student drives
    from the first round on, so the rows are the states it reaches (DAgger). ``VecNormalize``
    statistics are frozen meanwhile (the network's inputs keep their meaning) and its
    ``training`` flag restored after; the value network is left as it is.

    Returns the figures for ``run.json``: ``steps`` (rows), ``epochs``, ``weight``, per round
    (``rounds``) the driver's episodes and success share and its mean internal force on the
    new rows before the refit (``force_before``, as :func:`force_error`: a share of
    ``|tau_max|``), and after the last fit over all rows: ``force_after`` (the student's) and
    ``mse_after`` (its squared distance to the labels). ``stop`` ends it early (figures
    then say ``interrupted: True``). ``ValueError`` for a robot without an internal force or an
    action mode other than ``torque``.
    """

    from wheelgym.envs.baseline import baseline
    from wheelgym.tasks.tasks import internal_force_scale

    venv = model.get_env()
    core = baseline(venv).core  # the envs' core, found under SB3's wrappers
    _check_internal_force(core, "distill_internal_force")  # the error before the first step
    scale = internal_force_scale(core)
    policy = model.policy  # the teacher: a frozen copy (a deepcopy trips on torch's non-leaves)
    teacher = type(policy)(**policy._get_constructor_parameters()).to(policy.device)
    teacher.load_state_dict(policy.state_dict())
    teacher.set_training_mode(False)
    norm = model.get_vec_normalize_env()
    was_training = None if norm is None else norm.training
    if norm is not None:
        norm.training = False
    per = max(1, steps // rounds) // venv.num_envs
    obs = venv.reset()
    O: list[np.ndarray] = []
    A: list[np.ndarray] = []
    F: list[np.ndarray] = []
    log: list[dict[str, Any]] = []
    after = float("nan")
    try:
        for k in range(rounds):
            start = len(O)
            obs, episodes, successes = _distill_rows(model, teacher, core, scale, obs, per,
                                                     stop, O, A, F)
            new = slice(start, len(O))
            log.append({"episodes": episodes,
                        "success": round(successes / episodes, 4) if episodes else None,
                        "force_before": force_error(model, np.concatenate(O[new]),
                                                    np.concatenate(A[new]),
                                                    np.concatenate(F[new]))
                        if len(O) > start else None})
            if stop is not None and stop():
                break
            after = fit_mean(model, np.concatenate(O), np.concatenate(A),
                             epochs=epochs or EPOCHS, seed=seed + k, stop=stop,
                             force_rows=np.concatenate(F), force_weight=float(weight),
                             lr=lr)
    finally:
        if norm is not None:
            norm.training = was_training
    fit: dict[str, Any] = {"steps": int(sum(len(o) for o in O)), "epochs": epochs or EPOCHS,
                           "weight": float(weight), "rounds": log,
                           "mse_after": None if np.isnan(after) else after}
    if O:
        fit["force_after"] = force_error(model, np.concatenate(O), np.concatenate(A),
                                         np.concatenate(F))
    if stop is not None and stop():
        fit["interrupted"] = True
    return fit


def _distill_rows(model: Any, teacher: Any, core: Any, scale: float, obs: np.ndarray,
                  per: int, stop: Callable[[], bool] | None, O: list, A: list,
                  F: list) -> tuple[np.ndarray, int, int]:
    """One distillation round's rows: ``per`` vector steps in which the student drives and the
    teacher, less its internal force, labels (appended to ``O``, ``A``, ``F``); the last
    observation, and the episodes that ended and how many succeeded."""
    import torch as th

    venv = model.get_env()
    episodes = successes = 0
    for _ in range(max(1, per)):
        if stop is not None and O and stop():
            break
        with th.no_grad():
            label = teacher.predict(obs, deterministic=True)[0]
        N, tau_max = _null_space(core, "distill_internal_force")  # once per step
        O.append(np.asarray(obs, dtype=np.float32).copy())
        A.append(_less_internal_force(N, tau_max, label))
        F.append(_force_rows(N, tau_max, scale))
        act = model.predict(obs, deterministic=True)[0]
        obs, _, done, infos = venv.step(act)
        for i in np.flatnonzero(done):
            episodes += 1
            successes += bool(infos[i].get("is_success", False))
    return obs, episodes, successes


def _episodes(demo: Demonstration) -> dict[str, Any]:
    return {"episodes": demo.episodes,
            "success": round(demo.successes / demo.episodes, 4) if demo.episodes else None}
