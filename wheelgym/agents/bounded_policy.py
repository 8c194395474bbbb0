"""A PPO/A2C policy whose Gaussian mean cannot drift far past the action box.

SB3 clips each sampled action to the box before the environment sees it, so everything beyond
a bound acts alike: a reward term on the clipped action (the ``saturation`` term) is flat
there. Once the mean of a diagonal Gaussian has moved several standard deviations past a bound
no sample lands inside, that term carries no gradient, and the deterministic policy stays at
the bound (bang-bang) while paying it on every step. :class:`BoundedMeanPolicy` squashes the
mean to ``b tanh(x / b)``: for ``b`` a little above 1 the mean stays near the box, a sampled
action inside it keeps occurring, and the term can pull the mean back. The noise and its
log-probabilities are SB3's own (the squash acts on the mean only, unlike SAC's squashed
samples), so PPO's ratio and entropy are unchanged in form.

Selected by ``mean_bound: b`` in a config's ``policy_kwargs`` (:mod:`wheelgym.agents.config`);
a saved model records the class and ``mean_bound``, and ``PPO.load`` rebuilds it (wheelgym
must be importable).
"""

from __future__ import annotations

from typing import Any

import torch as th
from stable_baselines3.common.distributions import DiagGaussianDistribution, Distribution
from stable_baselines3.common.policies import ActorCriticPolicy

__all__ = ["BoundedMeanPolicy"]


class BoundedMeanPolicy(ActorCriticPolicy):
    """SB3's ``MlpPolicy`` (``ActorCriticPolicy``) with the action mean ``b tanh(x / b)``.

    Args:
        *args, **kwargs: those of ``ActorCriticPolicy``.
        mean_bound: ``b >= 1`` in units of the normalised action (the box is [-1, 1]).

    Raises:
        ValueError: ``mean_bound`` below 1 or not finite, or an action distribution other than
            the diagonal Gaussian (a Box action space without gSDE).
    """

    def __init__(self, *args: Any, mean_bound: float = 1.1, **kwargs: Any) -> None:
        b = float(mean_bound)
        if not (b >= 1.0 and b < float("inf")):
            raise ValueError(f"mean_bound must be a finite number >= 1, got {mean_bound!r}")
        super().__init__(*args, **kwargs)
        if not isinstance(self.action_dist, DiagGaussianDistribution):
            raise ValueError(f"mean_bound needs a diagonal Gaussian policy (Box actions, no "
                             f"gSDE), got {type(self.action_dist).__name__}")
        self.mean_bound = b

    def _get_action_dist_from_latent(self, latent_pi: th.Tensor) -> Distribution:
        b = self.mean_bound
        mean = b * th.tanh(self.action_net(latent_pi) / b)
        return self.action_dist.proba_distribution(mean, self.log_std)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data["mean_bound"] = self.mean_bound
        return data
