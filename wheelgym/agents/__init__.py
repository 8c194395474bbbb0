"""Training and evaluation of Stable-Baselines3 agents on wheelgym environments.

Needs the ``train`` extra (``pip install -e ".[train]"``). Submodules:

- :mod:`wheelgym.agents.config`: YAML configs (RL Zoo layout plus a ``wheelgym`` block)
- :mod:`wheelgym.agents.common`: SB3 algorithm, environments and ``VecNormalize`` from a config
- :mod:`wheelgym.agents.her`: hindsight relabelling whose relabelled successes end their transition
- :mod:`wheelgym.agents.policies`: the ``predict`` interface: agent, baseline and random policies
- :mod:`wheelgym.agents.evaluate`: one loop scoring agent, baseline and random on the same seeds
- :mod:`wheelgym.agents.train`: ``train(config)``, ``resume(run)``, run folders
- :mod:`wheelgym.agents.benchmark`: the results CSV and table over configs and seeds
- :mod:`wheelgym.agents.tune`: Optuna hyperparameter studies written back as configs
- :mod:`wheelgym.agents.pretrained`: the shipped agents of ``agents/pretrained/`` (export, load)

Layers, each importing only those before it: config <- common <- policies <- evaluate <- train
<- benchmark, tune; benchmark <- pretrained (``tests/agents/test_agents_layers.py`` keeps the
graph free of cycles).
Nothing here is imported by ``import wheelgym``.
"""

from wheelgym.agents.config import TrainConfig, load_config, parse_config

__all__ = ["TrainConfig", "load_config", "parse_config"]
