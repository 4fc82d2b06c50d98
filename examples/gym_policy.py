"""A policy driven through the gymnasium environment ``sitcov/TJunction-v0``.

``Policy`` maps the environment's observation (ego state, route points in the ego frame,
detections) to an action ``[throttle, brake, steer]``; it stands in for a learned policy
(an RL agent's ``predict`` or an imitation network). Run one episode per intersection
situation and print what happened (needs ``pip install 'sitcov[gym]'``)::

    python examples/gym_policy.py

The same policy tested by a whole campaign, as an AV stack (``PolicyStack``)::

    PYTHONPATH=. sitcov run --runs 100 --db policy.db --av examples.gym_policy:GymPolicyStack

or in Python: ``sitcov.gym.PolicyStack(my_policy)`` is an ``AVStack`` for any callable.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from sitcov.gym import PolicyStack

TARGET_SPEED = 25.0 / 3.6  # cruise speed [m/s]
STEER_GAIN = 0.9  # steer command per radian towards the route point 4 m ahead [1/rad]
BRAKE_WIDTH = 0.12  # brake when a confident car box covers this share of the width [-]


class Policy:
    """A hand-written policy: follow the route points, brake hard for close cars.

    Stateless within a run except for the brake latch, which ``reset()`` clears (a
    ``PolicyStack`` calls it at the start of every run).
    """

    def __init__(self) -> None:
        self.braking = False

    def reset(self) -> None:
        """Forget the previous run."""
        self.braking = False

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """The action for one observation."""
        speed = float(obs["ego"][3])
        x, y = (float(v) for v in obs["route"][1])  # the route point 4 m ahead, ego frame
        steer = max(-0.8, min(0.8, STEER_GAIN * math.atan2(y, x)))
        for x0, _, x1, _, score, valid in obs["detections"]:
            centre = 0.5 * (x0 + x1)
            if valid and score >= 0.5 and 0.05 < centre < 0.98 and x1 - x0 >= BRAKE_WIDTH:
                self.braking = True
        if self.braking:
            return np.array([0.0, 1.0, steer], dtype=np.float32)
        u = 0.3 * (TARGET_SPEED - speed)
        return np.array([min(max(u, 0.0), 0.75), min(max(-u, 0.0), 0.3), steer], dtype=np.float32)


class GymPolicyStack(PolicyStack):
    """:class:`Policy` as an AV stack, so ``sitcov run --av`` can load it by path."""

    name: ClassVar[str] = "gym-policy"

    def __init__(self) -> None:
        super().__init__(Policy(), name="examples.gym_policy.Policy")


def main(intsits: int = 12) -> None:
    """One episode for each of the first ``intsits`` intersection situations."""
    import gymnasium as gym

    from sitcov.gym import ENV_ID  # importing sitcov.gym registers the environment

    env = gym.make(ENV_ID)  # "sitcov/TJunction-v0"
    policy = Policy()
    for k in range(1, intsits + 1):
        obs, info = env.reset(seed=k, options={"situation": {"intsit": f"IntSit-{k}"}})
        policy.reset()
        total, steps, done = 0.0, 0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            total, steps, done = total + reward, steps + 1, terminated or truncated
        print(f"IntSit-{k:<2} {info['end_reason']:<12} steps {steps:4d}  return {total:7.1f}")
    env.close()


if __name__ == "__main__":
    main()
