"""A gymnasium environment on the embedded T-junction, and policies as AV stacks.

``sitcov/TJunction-v0`` (registered when this module is imported) lets reinforcement-
learning and imitation policies drive the ego through any situation of the hyperspace:
``env.reset(seed=..., options={"situation": situation})``. :class:`PolicyStack` turns such
a policy (observation -> action) back into an :class:`~sitcov.av.AVStack`, so a whole
campaign can test it like any other stack.

The backend keeps its closed loop ``run(situation, stack, seed)``: the environment runs
it in a worker thread with a bridge stack whose ``step`` hands the observation to
``env.step`` and waits for the action. Any backend works unchanged, and an episode is
exactly the run a campaign would make with the same situation and seed.

Observation (a ``Dict`` space, float32):

- ``ego``: ``[x, y, yaw, speed, t]`` [m, m, rad, m/s, s];
- ``route``: the next ``N_WAYPOINTS`` route points, :data:`WAYPOINT_SPACING` apart, in
  the ego frame (x forward, y left) [m], the last point repeated past the goal;
- ``detections``: up to ``MAX_DETECTIONS`` car detections of the latest frame, widest
  (closest) first, rows ``[x0/W, y0/H, x1/W, y1/H, score, valid]`` (zero rows after).

Detections come from the backend's PEM perception (its default); with camera perception
the environment gives no detections (a camera policy should be tested as a stack instead).

Action: ``Box([0, 0, -1], [1, 1, 1])`` = throttle, brake, steer (positive steers left).

Reward per step: metres of progress along the route minus ``collision_penalty`` (100 by
default) on the step a collision ends the episode. ``terminated`` when the run ends by
collision or at the goal; ``truncated`` at 60 s simulated (or ``max_time``) and when the
run ends for any other reason (ego stopped for good, error).
"""

from __future__ import annotations

import math
import queue
import threading
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import numpy as np

from sitcov.av._base import AVStack, Control, Observation, RunInfo
from sitcov.errors import ConfigError, MissingExtraError

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as exc:  # pragma: no cover - the optional extra
    raise MissingExtraError("the gymnasium environment", "gym", "gymnasium") from exc

#: The environment id.
ENV_ID = "sitcov/TJunction-v0"
#: Bound of the positions, angles [rad], speeds [m/s] and times [s] in an observation [m].
MAP_EXTENT = 1.0e4
#: Detections kept in an observation [-].
MAX_DETECTIONS = 8
#: Route points in an observation [-].
N_WAYPOINTS = 10
#: Spacing of the route points in an observation [m].
WAYPOINT_SPACING = 2.0
#: Reward subtracted on a collision [-].
COLLISION_PENALTY = 100.0
#: Simulated time after which an episode is truncated [s].
MAX_TIME = 60.0

Policy = Callable[[dict[str, np.ndarray]], Any]


def observation_space() -> spaces.Dict:
    """The observation space shared by the environment and :class:`PolicyStack`."""
    big = MAP_EXTENT
    return spaces.Dict(
        {
            "ego": spaces.Box(-big, big, shape=(5,), dtype=np.float32),
            "route": spaces.Box(-big, big, shape=(N_WAYPOINTS, 2), dtype=np.float32),
            "detections": spaces.Box(0.0, 1.0, shape=(MAX_DETECTIONS, 6), dtype=np.float32),
        }
    )


def action_space() -> spaces.Box:
    """Throttle [0, 1], brake [0, 1], steer [-1, 1]."""
    return spaces.Box(
        np.array([0.0, 0.0, -1.0], dtype=np.float32),
        np.array([1.0, 1.0, 1.0], dtype=np.float32),
        dtype=np.float32,
    )


class ObservationEncoder:
    """Turns the stack-side :class:`Observation` of a run into the fixed-size arrays.

    It tracks the ego's progress along the route (arc length of its projection) and
    holds the last frame's detections on steps without a new frame.
    """

    def __init__(self, info: RunInfo) -> None:
        route = [tuple(map(float, p)) for p in info.route] or [tuple(map(float, info.goal))]
        self.route = route
        self.cum = [0.0]
        for (x0, y0), (x1, y1) in zip(route, route[1:], strict=False):
            self.cum.append(self.cum[-1] + math.hypot(x1 - x0, y1 - y0))
        self.width = float(info.camera.width)
        self.height = float(info.camera.height)
        self.segment = 0
        self.progress = 0.0
        self.detections = np.zeros((MAX_DETECTIONS, 6), dtype=np.float32)

    def _project(self, x: float, y: float) -> float:
        """Advance along the route to the nearest segment ahead; return the arc length."""
        route, best, best_d, best_s = self.route, self.segment, math.inf, self.progress
        for i in range(self.segment, min(self.segment + 20, len(route) - 1)):
            (ax, ay), (bx, by) = route[i], route[i + 1]
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            u = ((x - ax) * dx + (y - ay) * dy) / length2 if length2 > 0.0 else 0.0
            u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
            px, py = ax + u * dx, ay + u * dy
            d = math.hypot(x - px, y - py)
            if d < best_d:
                best, best_d, best_s = i, d, self.cum[i] + u * math.sqrt(length2)
        self.segment = best
        return max(best_s, self.progress)

    def _point_at(self, s: float) -> tuple[float, float]:
        cum, route = self.cum, self.route
        if s >= cum[-1]:
            return route[-1]
        i = self.segment
        while i < len(cum) - 2 and cum[i + 1] < s:
            i += 1
        span = cum[i + 1] - cum[i]
        u = 0.0 if span == 0.0 else (s - cum[i]) / span
        (ax, ay), (bx, by) = route[i], route[i + 1]
        return ax + u * (bx - ax), ay + u * (by - ay)

    def encode(self, observation: Observation) -> tuple[dict[str, np.ndarray], float]:
        """The observation arrays and the progress made since the previous call [m]."""
        ego = observation.ego
        s = self._project(ego.x, ego.y)
        gained, self.progress = s - self.progress, s
        c, sn = math.cos(ego.yaw), math.sin(ego.yaw)
        route = np.empty((N_WAYPOINTS, 2), dtype=np.float32)
        for k in range(N_WAYPOINTS):
            px, py = self._point_at(s + (k + 1) * WAYPOINT_SPACING)
            dx, dy = px - ego.x, py - ego.y
            route[k] = (c * dx + sn * dy, -sn * dx + c * dy)
        if observation.detections is not None:
            rows = sorted(observation.detections, key=lambda d: d.box[2] - d.box[0], reverse=True)[
                :MAX_DETECTIONS
            ]
            det = np.zeros((MAX_DETECTIONS, 6), dtype=np.float32)
            for k, d in enumerate(rows):
                x0, y0, x1, y1 = d.box
                det[k] = (
                    x0 / self.width,
                    y0 / self.height,
                    x1 / self.width,
                    y1 / self.height,
                    d.score,
                    1.0,
                )
            self.detections = np.clip(det, 0.0, 1.0)
        obs = {
            "ego": np.array([ego.x, ego.y, ego.yaw, ego.speed, observation.t], dtype=np.float32),
            "route": route,
            "detections": self.detections.copy(),
        }
        return obs, gained


def action_to_control(action: Any) -> Control:
    """Clip an action (throttle, brake, steer) into a :class:`Control`."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ConfigError(
            field="action", value=action, expected="3 finite numbers (throttle, brake, steer)"
        )
    return Control(
        throttle=float(min(1.0, max(0.0, a[0]))),
        brake=float(min(1.0, max(0.0, a[1]))),
        steer=float(min(1.0, max(-1.0, a[2]))),
    )


class PolicyStack(AVStack):
    """An AV stack driven by a gymnasium-style policy ``observation -> action``.

    The policy sees exactly what :data:`ENV_ID` gives it, so a policy trained in the
    environment runs unchanged in a campaign. If the policy has a ``reset()`` method it
    is called at the start of every run (for recurrent state).

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


class _Abort(BaseException):
    """Ends an episode's worker thread (BaseException: a backend cannot swallow it)."""


class _Bridge(AVStack):
    """The stack the backend drives in the worker thread: it waits for ``env.step``."""

    name: ClassVar[str] = "gym"

    def __init__(self, events: queue.Queue, actions: queue.Queue) -> None:
        self.events, self.actions = events, actions
        self.info: RunInfo | None = None

    def reset(self, info: RunInfo) -> None:
        self.info = info
        self.camera = info.camera

    def step(self, observation: Observation) -> Control:
        self.events.put(("obs", observation))
        action = self.actions.get()
        if action is None:
            raise _Abort
        return action


class TJunctionEnv(gym.Env):
    """The embedded T-junction as a gymnasium environment (see the module docstring).

    Args:
        backend: a backend instance; default ``make_backend("embedded", **backend_options)``.
        hyperspace: the hyperspace situations come from (default: the built-in t-junction).
        backend_options: options of the default backend (e.g. ``{"perception": "pem"}``).
        collision_penalty: reward subtracted on a collision [-].
        max_time: simulated seconds after which the episode is truncated [s].
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(
        self,
        backend: Any = None,
        hyperspace: Any = None,
        backend_options: Mapping[str, Any] | None = None,
        collision_penalty: float = COLLISION_PENALTY,
        max_time: float = MAX_TIME,
    ) -> None:
        if backend is None:
            from sitcov.sim import make_backend

            backend = make_backend("embedded", **dict(backend_options or {}))
        if hyperspace is None or isinstance(hyperspace, str):
            from sitcov.hyperspace import load_hyperspace

            hyperspace = load_hyperspace(hyperspace)
        self.backend = backend
        self.hyperspace = hyperspace
        self.collision_penalty = float(collision_penalty)
        self.max_time = float(max_time)
        self.observation_space = observation_space()
        self.action_space = action_space()
        self.situation: Any = None
        self.outcome: Any = None
        self._thread: threading.Thread | None = None
        self._events: queue.Queue = queue.Queue()
        self._actions: queue.Queue = queue.Queue()
        self._encoder: ObservationEncoder | None = None
        self._last: dict[str, np.ndarray] | None = None

    # -- episode control -----------------------------------------------------------------

    def _situation(self, options: Mapping[str, Any] | None) -> Any:
        from sitcov.hyperspace import Situation

        given = (options or {}).get("situation")
        if isinstance(given, Situation):
            return given
        if isinstance(given, Mapping):
            if "values" in given:
                return Situation.from_dict(given)
            bins = dict(given.get("bins", given))
            for name in self.hyperspace.element_names:
                if name not in bins:
                    labels = self.hyperspace.labels(name)
                    bins[name] = labels[int(self.np_random.integers(len(labels)))]
            return self.hyperspace.situation_from_bins(bins, self.np_random)
        if given is None:
            return self._situation({"situation": {}})
        raise ConfigError(
            field="options.situation",
            value=given,
            expected="a Situation, its to_dict() form, or a mapping element -> bin label",
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start a run of ``options["situation"]`` (random bins for elements not given).

        ``options["run_seed"]`` fixes the simulation seed (default: drawn from the
        environment's generator, so ``seed`` reproduces the episode).
        """
        super().reset(seed=seed)
        self._stop()
        self.situation = self._situation(options)
        run_seed = (options or {}).get("run_seed")
        if run_seed is None:
            run_seed = int(self.np_random.integers(2**32))
        self.outcome = None
        self._events, self._actions = queue.Queue(), queue.Queue()
        bridge = _Bridge(self._events, self._actions)
        self._thread = threading.Thread(
            target=self._worker,
            args=(bridge, self.situation, int(run_seed)),
            daemon=True,
            name="sitcov-gym-episode",
        )
        self._thread.start()
        kind, payload = self._events.get()
        if kind != "obs":
            self._finish(kind, payload)
            raise ConfigError(f"the backend ended the run before its first step: {self.outcome}")
        self._encoder = ObservationEncoder(bridge.info)
        obs, _ = self._encoder.encode(payload)
        self._last = obs
        info = {
            "situation": self.situation.to_dict(),
            "run_seed": int(run_seed),
            "route": [list(p) for p in bridge.info.route],
        }
        return obs, info

    def _worker(self, bridge: _Bridge, situation: Any, seed: int) -> None:
        try:
            outcome = self.backend.run(situation, bridge, seed)
            self._events.put(("end", outcome))
        except _Abort:
            self._events.put(("aborted", None))
        except BaseException as exc:  # reported to the caller of step()
            self._events.put(("exception", exc))

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        """Apply the action for one control period; see the module docstring for rewards."""
        if self._thread is None or self._encoder is None:
            raise ConfigError("call reset() before step() (and again after an episode ends)")
        self._actions.put(action_to_control(action))
        kind, payload = self._events.get()
        if kind == "obs":
            obs, gained = self._encoder.encode(payload)
            self._last = obs
            if payload.t >= self.max_time:
                self._stop()
                return obs, gained, False, True, {"end_reason": "max_time"}
            return obs, gained, False, False, {}
        self._finish(kind, payload)
        outcome = self.outcome
        reward = -self.collision_penalty if outcome.collision else 0.0
        terminated = outcome.end_reason in ("collision", "goal")
        info = {"outcome": outcome.to_dict(), "end_reason": outcome.end_reason}
        return self._last, reward, terminated, not terminated, info

    def _finish(self, kind: str, payload: Any) -> None:
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()
        self._encoder = None
        if kind == "exception":
            raise payload
        self.outcome = payload

    def _stop(self) -> None:
        """Abort a running episode and wait for its thread."""
        thread, self._thread = self._thread, None
        if thread is not None and thread.is_alive():
            self._actions.put(None)
            thread.join()
        self._encoder = None

    def close(self) -> None:
        """Stop any running episode and release the backend."""
        self._stop()
        close = getattr(self.backend, "close", None)
        if callable(close):
            close()


if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="sitcov.av._gym:TJunctionEnv")
