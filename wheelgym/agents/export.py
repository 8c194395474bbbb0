"""A trained agent's deterministic policy as one ONNX graph (``wheelgym export``).

The graph computes what :meth:`AgentPolicy.predict(obs, deterministic=True)
<wheelgym.agents.policies.AgentPolicy.predict>` returns, for a batch of observations, in three
parts (docs/topics/export.md):

1. the run's ``VecNormalize`` observation statistics, frozen:
   ``clip((obs - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)`` in float64, as
   ``VecNormalize.normalize_obs`` computes it (only the keys it normalises, for Dict
   observations), then float32, as SB3's preprocessing feeds the network;
2. the policy's deterministic action, through Stable-Baselines3's documented export path
   (``policy(observation, deterministic=True)``; its preprocessing included): the Gaussian's
   mean for PPO and A2C (``mean_bound`` squash included), ``tanh`` of it for SAC, the actor's
   output for TD3;
3. what ``predict`` does to a ``Box`` action afterwards: the squashed policies' actions (SAC,
   TD3) unscaled from [-1, 1] to the space's bounds, the others clipped to them.

Inputs: ``obs`` (``(batch, n)``, the observation space's dtype) for a Box observation, or one
input per key of a Dict observation (named after the key, in the space's order, each of its
dtype); output ``action`` (``(batch, action_dim)`` float32). The file holds its weights (one
file) and metadata properties ``wheelgym.*`` (env id and keyword arguments as JSON, algorithm,
source, inputs). A ``source`` is a run folder (``config.yml`` plus ``model.zip``, or
``best_model.zip`` with ``best``) or a shipped agent's name (a config name or config path; see
:mod:`wheelgym.agents.pretrained`). Needs the ``onnx`` extra (``onnx``, ``onnxruntime``,
``onnxscript``: torch's exporter) beside the ``train`` one.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import logging
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from wheelgym.agents.config import TrainConfig, load_config
from wheelgym.agents.policies import AgentPolicy, load_agent

__all__ = ["ExportResult", "load_source", "check_onnx_path", "policy_module", "export_onnx",
           "onnx_actions", "sample_observations", "check_export", "DEFAULT_OPSET"]

#: The ONNX opset of the exported graph.
DEFAULT_OPSET = 18

#: Prefix of the metadata properties written into the graph.
META = "wheelgym."


@dataclasses.dataclass(frozen=True)
class ExportResult:
    """One export: the file, its inputs and output, and where the agent came from.

    Attributes:
        path: the ``.onnx`` file written.
        inputs: input name -> (dtype name, per-row shape).
        action_dim: entries of the ``action`` output per row.
        source: the run folder or shipped agent's name.
        algo: ``ppo``, ``sac``, ``td3`` or ``a2c``.
        env_id: the agent's env id; ``env_kwargs``: its keyword arguments.
    """

    path: Path
    inputs: dict[str, tuple[str, tuple[int, ...]]]
    action_dim: int
    source: str
    algo: str
    env_id: str
    env_kwargs: dict[str, Any]


def _onnx_modules():
    try:
        import onnx
        import onnxscript  # noqa: F401  (torch's exporter needs it)
    except ImportError as e:
        raise ValueError(f"wheelgym export needs the onnx extra: pip install "
                         f"'wheelgym[train,onnx]' ({e})") from None
    return onnx


def load_source(source: str | Path, best: bool = False, root: str | Path | None = None
                ) -> tuple[AgentPolicy, TrainConfig, str]:
    """The agent, its config and a label for ``source``: a run folder (its ``model.zip``, or
    ``best_model.zip`` with ``best``, and the statistics next to it), else a shipped agent's
    name (``root``: another folder of agents)."""
    path = Path(source)
    if path.is_dir() and (path / "config.yml").is_file():
        config = load_config(path / "config.yml")
        stem, stats = ("best_model", "best_vecnormalize.pkl") if best else (
            "model", "vecnormalize.pkl")
        if not (path / f"{stem}.zip").is_file():
            raise ValueError(f"{path}: no {stem}.zip")
        if config.normalize is not None and not (path / stats).is_file():
            raise ValueError(f"{path}: the config normalises observations but {stats} is "
                             "missing")
        agent = load_agent(path / f"{stem}.zip", config.algo, path / stats, device="cpu")
        return agent, config, str(path)
    if path.is_dir():
        raise ValueError(f"{path}: not a run folder (no config.yml)")
    if best:
        raise ValueError("--best applies to a run folder (a shipped agent is one final model)")
    from wheelgym.agents.pretrained import available, load_pretrained

    text = str(source)
    name = Path(text).stem if text.endswith((".yml", ".yaml")) else text
    if name not in available(root):
        raise ValueError(f"{source!r} is neither a run folder nor a shipped agent; shipped: "
                         f"{available(root)}")
    agent, config = load_pretrained(name, root=root, device="cpu")
    return agent, config, name


def _obs_keys(space: Any) -> list[str] | None:
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return list(space.spaces)
    if not isinstance(space, spaces.Box):
        raise ValueError(f"export takes Box or Dict observations, got {type(space).__name__}")
    return None


def policy_module(agent: AgentPolicy):
    """A ``torch.nn.Module`` computing ``agent.predict(obs, deterministic=True)`` for a batch:
    ``module(obs)`` (Box observations) or ``module(*tensors)`` in the Dict space's key order.
    """
    import torch as th
    from gymnasium import spaces

    policy = agent.model.policy
    if not isinstance(policy.action_space, spaces.Box):
        raise ValueError(f"export takes Box actions, got {type(policy.action_space).__name__}")
    keys = _obs_keys(policy.observation_space)
    vn = agent.obs_norm if agent.obs_norm is not None and agent.obs_norm.norm_obs else None

    class OnnxablePolicy(th.nn.Module):
        """Normalisation, SB3's deterministic policy, predict's post-processing."""

        def __init__(self) -> None:
            super().__init__()
            self.policy = policy
            self.keys = keys
            self.clip = float(vn.clip_obs) if vn is not None else 0.0
            self.norm: list[str] = []
            if vn is not None:
                stats = vn.obs_rms if keys is None else {k: vn.obs_rms[k]
                                                         for k in vn.norm_obs_keys}
                for k, rms in ([("obs", stats)] if keys is None else stats.items()):
                    # the float64 statistics and the divisor as VecNormalize computes them
                    self.register_buffer(f"mean_{k}", th.as_tensor(rms.mean, dtype=th.float64))
                    self.register_buffer(f"std_{k}", th.as_tensor(
                        np.sqrt(rms.var + vn.epsilon), dtype=th.float64))
                    self.norm.append(k)
            box = policy.action_space
            self.squash = bool(policy.squash_output)
            self.register_buffer("low", th.as_tensor(box.low, dtype=th.float32))
            self.register_buffer("high", th.as_tensor(box.high, dtype=th.float32))

        def _normalise(self, k: str, x):
            if k not in self.norm:
                return x.to(th.float32)
            z = (x.to(th.float64) - getattr(self, f"mean_{k}")) / getattr(self, f"std_{k}")
            return th.clamp(z, -self.clip, self.clip).to(th.float32)

        def forward(self, *inputs):
            if self.keys is None:
                obs = self._normalise("obs", inputs[0])
            else:
                obs = {k: self._normalise(k, x) for k, x in zip(self.keys, inputs, strict=True)}
            out = self.policy(obs, deterministic=True)  # SB3's export path
            action = out[0] if isinstance(out, tuple) else out  # PPO/A2C: (action, value, logp)
            if self.squash:  # BasePolicy.unscale_action
                return self.low + 0.5 * (action + 1.0) * (self.high - self.low)
            return th.maximum(th.minimum(action, self.high), self.low)

    return OnnxablePolicy().eval()


def _input_specs(agent: AgentPolicy) -> dict[str, tuple[np.dtype, tuple[int, ...]]]:
    space = agent.model.policy.observation_space
    keys = _obs_keys(space)
    if keys is None:
        return {"obs": (np.dtype(space.dtype), tuple(space.shape))}
    return {k: (np.dtype(space[k].dtype), tuple(space[k].shape)) for k in keys}


def check_onnx_path(path: str | Path) -> Path:
    """``path`` as a ``Path`` if an ONNX file can be written there (``ValueError`` if not)."""
    path = Path(path)
    if path.suffix != ".onnx":
        raise ValueError(f"--onnx {str(path)!r}: the file name must end in .onnx")
    if path.is_dir():
        raise ValueError(f"--onnx {str(path)!r} is a folder; give a file name")
    if not path.parent.is_dir():
        raise ValueError(f"--onnx {str(path)!r}: folder {str(path.parent)!r} does not exist")
    return path


def export_onnx(source: str | Path | AgentPolicy, path: str | Path, *,
                config: TrainConfig | None = None, best: bool = False,
                root: str | Path | None = None, opset: int = DEFAULT_OPSET) -> ExportResult:
    """Write the deterministic policy of ``source`` (a run folder, a shipped agent's name, or
    an :class:`AgentPolicy` with its ``config``) to ``path`` as one ONNX file (see the module
    docstring). The batch axis is dynamic. ``ValueError`` for a source that is not an agent, a
    space the export does not take, or a missing ``onnx`` extra."""
    onnx = _onnx_modules()
    import torch as th

    path = check_onnx_path(path)
    if isinstance(source, AgentPolicy):
        if config is None:
            raise ValueError("export_onnx(agent, ...) needs the agent's config=")
        agent, label = source, source.name
    else:
        agent, config, label = load_source(source, best=best, root=root)
    module = policy_module(agent)
    specs = _input_specs(agent)
    dummy = tuple(th.zeros((2, *shape), dtype=getattr(th, dt.name)) for dt, shape in
                  specs.values())
    batch = th.export.Dim("batch")
    validate = th.distributions.Distribution._validate_args
    th.distributions.Distribution.set_default_validate_args(False)  # no data-dependent checks
    quiet = logging.getLogger("torch.onnx")  # its notes on optional operator sets
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(), th.no_grad():
            warnings.simplefilter("ignore")
            program = th.onnx.export(
                module, dummy, input_names=list(specs), output_names=["action"],
                dynamic_shapes=(tuple({0: batch} for _ in specs),), opset_version=opset,
                dynamo=True, verbose=False, optimize=True)
    finally:
        th.distributions.Distribution.set_default_validate_args(validate)
        quiet.setLevel(level)
    model = program.model_proto
    meta = {"env_id": config.env_id, "env_kwargs": json.dumps(config.env_kwargs, sort_keys=True),
            "algo": config.algo, "source": label, "inputs": json.dumps(list(specs)),
            "normalize": json.dumps(bool(module.norm))}
    for k, v in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = META + k, str(v)
    onnx.checker.check_model(model)
    onnx.save_model(model, str(path), save_as_external_data=False)
    return ExportResult(path=path, inputs={k: (dt.name, s) for k, (dt, s) in specs.items()},
                        action_dim=int(agent.model.policy.action_space.shape[0]),
                        source=label, algo=config.algo, env_id=config.env_id,
                        env_kwargs=dict(config.env_kwargs))


def onnx_actions(path: str | Path, obs: np.ndarray | dict[str, np.ndarray]) -> np.ndarray:
    """The exported graph's actions for a batch (ONNX Runtime on the CPU)."""
    try:
        import onnxruntime as ort
    except ImportError as e:
        raise ValueError(f"running an exported policy needs onnxruntime (the onnx extra): "
                         f"{e}") from None
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    names = [i.name for i in session.get_inputs()]
    feed = {"obs": obs} if not isinstance(obs, dict) else obs
    return session.run(["action"], {k: np.asarray(feed[k]) for k in names})[0]


def sample_observations(agent: AgentPolicy, n: int, seed: int = 0
                        ) -> np.ndarray | dict[str, np.ndarray]:
    """``n`` observations drawn from the agent's observation space (seeded), as a batch."""
    space = copy.deepcopy(agent.model.policy.observation_space)  # its own generator
    space.seed(seed)
    rows = [space.sample() for _ in range(n)]
    if isinstance(rows[0], dict):
        return {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    return np.stack(rows)


def check_export(path: str | Path, agent: AgentPolicy,
                 obs: np.ndarray | dict[str, np.ndarray]) -> float:
    """The largest ``|a_onnx - a_sb3|`` over a batch of observations (``a_sb3``:
    ``agent.predict(obs, deterministic=True)``)."""
    ref = np.asarray(agent.predict(obs, deterministic=True)[0])
    got = onnx_actions(path, obs)
    if got.shape != ref.shape:
        raise ValueError(f"{path}: actions of shape {got.shape}, SB3 gives {ref.shape}")
    return float(np.max(np.abs(got.astype(np.float64) - ref.astype(np.float64))))
