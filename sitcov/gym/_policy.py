"""Policies as AV stacks: a gymnasium-style policy tested by a whole campaign."""

from __future__ import annotations

from typing import Any, ClassVar

from sitcov.av import AVStack, Control, Observation, RunInfo
from sitcov.gym._spaces import ObservationEncoder, Policy, action_to_control


class PolicyStack(AVStack):
    """An AV stack driven by a gymnasium-style policy ``observation -> action``.

    The policy sees exactly what :data:`~sitcov.gym.ENV_ID` gives it, so a policy trained
    in the environment runs unchanged in a campaign. If the policy has a ``reset()``
    method it is called at the start of every run (for recurrent state).

    Args:
        policy: a callable mapping the observation dict to ``[throttle, brake, steer]``.
        name: stored with each run's configuration.
    """

    name: ClassVar[str] = "policy"

    def __init__(self, policy: Policy, name: str | None = None) -> None:
        self.policy = policy
        self.policy_name = name or type(policy).__name__
        self._encoder: ObservationEncoder | None = None

    def reset(self, info: RunInfo) -> None:
        """Start tracking the new run's route; reset the policy if it can be."""
        self._encoder = ObservationEncoder(info)
        self.camera = info.camera
        reset = getattr(self.policy, "reset", None)
        if callable(reset):
            reset()

    def step(self, observation: Observation) -> Control:
        """Encode, ask the policy, clip."""
        assert self._encoder is not None, "reset() must be called before step()"
        obs, _ = self._encoder.encode(observation)
        return action_to_control(self.policy(obs))

    def config(self) -> dict[str, Any]:
        """The policy's name (and its ``config()`` if it has one)."""
        data: dict[str, Any] = {"name": self.name, "policy": self.policy_name}
        extra = getattr(self.policy, "config", None)
        if callable(extra):
            data["policy_config"] = extra()
        return data
