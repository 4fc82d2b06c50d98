"""The environment ``sitcov/TJunction-v0``: a backend's closed loop, one step per ``env.step``.

The backend keeps its closed loop ``run(situation, stack, seed)``: the environment runs
it in a worker thread with a bridge stack whose ``step`` hands the observation to
``env.step`` and waits for the action. Any backend works unchanged, and an episode is
exactly the run a campaign would make with the same situation and seed. Observation,
action and reward are described in :mod:`sitcov.gym`.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Mapping
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from sitcov.av import AVStack, Control, Observation, RunInfo
from sitcov.errors import ConfigError
from sitcov.gym._spaces import (
    ObservationEncoder,
    action_space,
    action_to_control,
    observation_space,
)
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim import make_backend

#: The environment id (registered by importing :mod:`sitcov.gym`).
ENV_ID = "sitcov/TJunction-v0"
#: Reward subtracted on a collision [-].
COLLISION_PENALTY = 100.0
#: Simulated time after which an episode is truncated [s].
MAX_TIME = 60.0


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
    """The embedded T-junction as a gymnasium environment (see :mod:`sitcov.gym`).

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
            backend = make_backend("embedded", **dict(backend_options or {}))
        if hyperspace is None or isinstance(hyperspace, str):
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
        """Apply the action for one control period; see :mod:`sitcov.gym` for rewards."""
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
