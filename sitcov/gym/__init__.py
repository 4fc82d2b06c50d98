"""A gymnasium environment on the embedded T-junction, and policies as AV stacks.

Needs the optional extra ``sitcov[gym]``. Importing this package registers
``sitcov/TJunction-v0`` (:data:`ENV_ID`), which lets reinforcement-learning and imitation
policies drive the ego through any situation of the hyperspace:
``env.reset(seed=..., options={"situation": situation})``. :class:`PolicyStack` turns such
a policy (observation -> action) back into an :class:`~sitcov.av.AVStack`, so a whole
campaign can test it like any other stack. The environment runs a simulator, so this
package stands above :mod:`sitcov.sim` (and :mod:`sitcov.av`, which the simulator drives).

Observation (a ``Dict`` space, float32):

- ``ego``: ``[x, y, yaw, speed, t]`` [m, m, rad, m/s, s];
- ``route``: the next :data:`N_WAYPOINTS` route points, :data:`WAYPOINT_SPACING` apart, in
  the ego frame (x forward, y left) [m], the last point repeated past the goal;
- ``detections``: up to :data:`MAX_DETECTIONS` car detections of the latest frame, widest
  (closest) first, rows ``[x0/W, y0/H, x1/W, y1/H, score, valid]`` (zero rows after).

Detections come from the backend's PEM perception (its default); with camera perception
the environment gives no detections (a camera policy should be tested as a stack instead).

Action: ``Box([0, 0, -1], [1, 1, 1])`` = throttle, brake, steer (positive steers left).

Reward per step: metres of progress along the route minus ``collision_penalty`` (100 by
default) on the step a collision ends the episode. ``terminated`` when the run ends by
collision or at the goal; ``truncated`` at 60 s simulated (or ``max_time``) and when the
run ends for any other reason (ego stopped for good, error).
"""

from sitcov.errors import MissingExtraError

try:
    import gymnasium
except ImportError as exc:  # pragma: no cover - the optional extra
    raise MissingExtraError("the gymnasium environment", "gym", "gymnasium") from exc

from sitcov.gym._env import COLLISION_PENALTY, ENV_ID, MAX_TIME, TJunctionEnv
from sitcov.gym._policy import PolicyStack
from sitcov.gym._spaces import (
    MAX_DETECTIONS,
    N_WAYPOINTS,
    WAYPOINT_SPACING,
    action_space,
    observation_space,
)

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="sitcov.gym:TJunctionEnv")

__all__ = [
    "COLLISION_PENALTY",
    "ENV_ID",
    "MAX_DETECTIONS",
    "MAX_TIME",
    "N_WAYPOINTS",
    "WAYPOINT_SPACING",
    "PolicyStack",
    "TJunctionEnv",
    "action_space",
    "observation_space",
]
