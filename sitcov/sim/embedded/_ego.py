"""The ego's controller: the AV stack under test, fed by simulated perception.

:class:`EgoDriver` does per step what stands between the world and the stack: at the
sensor rate it makes the observation the stack wants (``EmbeddedBackend.observation_kind``):
detections from the sensor (PEM mode: ``Sensor.detect`` with an ``ActorView`` per actor,
``kind`` set, or for the built-in PEM the same through ``PEMSensor.detect_prepared``), a
rendered frame (camera mode; one that repeats the last rendered frame is handed again, not
rendered), the real detector's detections on that frame (camera mode, a stack that wants
detections) or an object list (either mode), delays frames by
the perception delay, asks the stack for a ``Control``, notes when its AEB fired (if it
latched, perception stops from then on: the stack ignores it; an AEB that releases keeps
receiving frames), and delays the brake command by the
brake delay (throttle and steering act at once).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from sitcov.av._base import EgoState, Observation
from sitcov.perception._base import Pose
from sitcov.perception._objects import ObjectMisses, object_list
from sitcov.perception._pem import NormalStream, PEMSensor

#: The built-in PEM's normals are drawn this many at a time (``NormalStream``): its noise
#: is the run generator's last consumer (the wind's draws come first), so drawing ahead
#: changes no value (``tests/sim/test_sim_world.py`` checks that no draw follows). A run
#: of the default campaign uses about 800 (blocks of 128 took six numpy calls and five
#: array joins per run; one block of 1024 usually covers it).
NOISE_BLOCK = 1024
#: Spawn key of the object lists' noise stream (``default_rng(SeedSequence(seed,
#: spawn_key=(OBJECTS_KEY,)))``): its draws shift no other draw of the run. "OBJ" in ASCII.
OBJECTS_KEY = 0x4F424A


class EgoDriver:
    """Drives the ego actor with ``stack`` (one instance per run).

    Args:
        backend: the embedded backend (camera-mode frame gating and rendering).
        stack: the AV stack under test (already ``reset``).
        sensor: the PEM-mode sensor, or None in camera mode.
        conditions: the run's conditions (sensors read them).
        rng: the run's generator (sensor noise draws); another run seed's with the
            backend's ``perception_seed``.
        seed: the seed of the perception's draws (camera frames and object lists get their
            own generators from it): the run's, or the backend's ``perception_seed``.
        delay_p, delay_b: perception and brake delays in control periods.
        gate_px: camera mode: the true box width below which no frame is rendered.
        kind: what the stack observes: ``detections`` (the sensor), ``image``,
            ``camera-detections`` (the backend's detector on the frame) or ``objects``.
    """

    def __init__(
        self,
        backend: Any,
        stack: Any,
        sensor: Any,
        conditions: Any,
        rng: np.random.Generator,
        seed: int,
        delay_p: int,
        delay_b: int,
        gate_px: float,
        kind: str = "detections",
    ) -> None:
        self.backend, self.stack, self.sensor = backend, stack, sensor
        self.cond, self.rng, self.seed = conditions, rng, seed
        self.every = backend.sensor_every
        self.delay_p = delay_p
        self.frames: deque[tuple[int, Any, Any]] = deque()
        self.brakes: deque[float] = deque([0.0] * delay_b)
        self.gate_px = gate_px
        self.camera = stack.camera
        self.latched = False  # the AEB latched: no more frames or detections
        self.kind = kind
        self.camera_mode = kind in ("image", "camera-detections")
        # camera mode: (pose, actor views, image or detections) of the last rendered frame
        # while frames repeat (see _perceive), and whether they do in this run's weather
        self._last_frame: tuple[Any, Any, Any] | None = None
        self._repeats: bool | None = None
        self.objects_rng = (
            np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(OBJECTS_KEY,)))
            if kind == "objects" and backend.object_noise is not None
            else None
        )
        # the object lists' latent misses, this run
        self.object_misses = ObjectMisses() if kind == "objects" else None
        self.aeb_time: float | None = None
        plain = getattr(type(stack), "plain_step", None)  # the built-in stack's fast path
        self.plain_step = plain(stack) if callable(plain) and kind != "objects" else None
        # whether the built-in stack's AEB latches when it fires (else it releases)
        self.plain_latches = bool(getattr(stack, "aeb_latches", True))
        # the built-in PEM (its detect not overridden): each actor prepared once per run,
        # then shown by its body's pose (no Pose or ActorView per frame)
        self.prepared = sensor is not None and type(sensor).detect is PEMSensor.detect
        self._looks: list[tuple[Any, Any]] | None = None  # (actor, prepared) per actor
        self._seen_all: list[tuple[Any, Any]] | None = None  # (prepared, body), all active
        self._normals = NormalStream(rng, NOISE_BLOCK)
        self._frame_detect: Any = None  # the PEM's frame_detector, at the first frame
        if self.plain_step is not None and self.prepared and not delay_p:
            # the usual run (the built-in stack on the built-in PEM, no perception delay):
            # command's branches for it alone, decided once (an instance attribute)
            self.command = self._command_plain  # type: ignore[method-assign]

    def release(self) -> None:
        """The run is over: forget the plain path's bound ``command`` (an instance
        attribute holding this driver: a reference cycle; ``World.release``)."""
        self.__dict__.pop("command", None)

    def _detect_prepared(self, world: Any) -> Any:
        """The PEM's detections for this frame through ``PEMSensor.detect_prepared``."""
        looks = self._looks
        if looks is None:
            prepare, cond = self.sensor.prepare_parts, self.cond
            looks = self._looks = [
                (a, look) for a in world.actors for look in prepare(a.view(), cond)
            ]  # one per detection the road user gives (a cyclist's rider and bicycle)
            self._seen_all = [(look, a.body) for a, look in looks]
        ego = world.ego.body
        seen = self._seen_all  # every actor active (none comes back once it left)
        if seen is not None:
            for a, _ in looks:
                if not a.active:
                    seen = self._seen_all = None
                    break
        if seen is None:
            seen = [(look, a.body) for a, look in looks if a.active]
        detect = self._frame_detect
        if detect is None:
            detect = self._frame_detect = self.sensor.frame_detector(self.cond, self._normals)
        return detect(ego.x, ego.y, ego.yaw, seen)

    def _objects(self, world: Any, t: float) -> Any:
        """The object list of this frame at time ``t`` [s] (ground truth + the backend's
        noise model, its misses correlated in time through ``self.object_misses``)."""
        ego = world.ego.body
        seen = [(i + 1, a.view(), *a.velocity()) for i, a in enumerate(world.actors) if a.active]
        return object_list(
            Pose(ego.x, ego.y, ego.yaw),
            seen,
            mount_x=self.camera.mount_x,
            conditions=self.cond,
            noise=self.backend.object_noise,
            rng=self.objects_rng,
            misses=self.object_misses,
            time=t,
        )

    def _perceive(self, world: Any, k: int) -> tuple[Any, Any]:
        """(detections, image) captured at step ``k`` (a frame step)."""
        ego = world.ego.body
        actors = tuple([a.view() for a in world.actors if a.active])
        pose = Pose(ego.x, ego.y, ego.yaw)
        if not self.camera_mode:
            return self.sensor.detect(pose, actors, self.cond, self.rng), None
        backend = self.backend
        if not backend._needs_frame(self.camera, pose, actors, self.gate_px):
            return (), None  # camera mode, no road user in view (see _needs_frame)
        if backend.frame_observer is not None:
            backend.frame_observer(self.camera, pose, actors, self.cond)
        last = self._last_frame
        if last is not None and last[0] == pose and last[1] == actors:
            # nothing moved since the last rendered frame and the renderer draws nothing
            # at random: the same pixels, so the same detections (a stopped ego holding
            # for a stopped road user renders and detects nothing new)
            if self.kind == "camera-detections":
                return last[2], None
            return None, last[2].copy()
        # one generator per frame: which frames are rendered changes no other draw
        frame_rng = np.random.default_rng([self.seed, k])
        image = backend._frame(self.camera, pose, actors, self.cond, frame_rng)
        if self._repeats is None:
            self._repeats = backend._frames_repeat(self.cond)
        if self.kind == "camera-detections":
            detections = backend._detect(image)
            if self._repeats:
                self._last_frame = (pose, actors, detections)
            return detections, None
        if self._repeats:  # kept unchanged: the stack may write into its copy
            self._last_frame = (pose, actors, image.copy())
        return None, image

    def command(self, world: Any, k: int, t: float) -> tuple[float, float, float]:
        """(throttle, brake, steer) of the ego for step ``k`` at time ``t``."""
        objects = None
        if k % self.every or self.latched:
            detections = image = None
        elif self.prepared:
            detections, image = self._detect_prepared(world), None
        elif self.kind == "objects":
            detections = image = None
            objects = self._objects(world, t)
        else:
            detections, image = self._perceive(world, k)
        if self.delay_p:
            if detections is not None or image is not None or objects is not None:
                self.frames.append((k + self.delay_p, detections, image, objects))
            detections = image = objects = None
            if self.frames and self.frames[0][0] == k:
                _, detections, image, objects = self.frames.popleft()
        ego = world.ego.body
        if self.plain_step is not None:  # the built-in stack: no per-step objects
            throttle, brake, steer, fired = self.plain_step(
                t, ego.x, ego.y, ego.yaw, world.ego_speed, detections, image
            )
            latches = fired is not None and self.plain_latches
        else:
            throttle, brake, steer, fired = self._step(
                ego, world.ego_speed, t, detections, image, objects
            )
            latches = fired is True
        if fired is not None:
            if self.aeb_time is None:
                self.aeb_time = t
            # no more frames (camera) or detections (PEM) once the brake has latched:
            # Control.info["aeb"] promises the stack ignores perception from now on, and
            # the sensor's noise draws come last from the run's generator, so skipping
            # them changes no other draw. An AEB that releases keeps perceiving.
            self.latched = latches
        if self.brakes:
            self.brakes.append(brake)
            brake = self.brakes.popleft()
        return throttle, brake, steer

    def _command_plain(self, world: Any, k: int, t: float) -> tuple[float, float, float]:
        """:meth:`command` for the built-in stack on the built-in PEM without perception
        delay: the same steps, the branches that cannot apply left out."""
        detections = None if k % self.every or self.latched else self._detect_prepared(world)
        ego = world.ego.body
        throttle, brake, steer, fired = self.plain_step(
            t, ego.x, ego.y, ego.yaw, world.ego_speed, detections, None
        )
        if fired is not None:
            if self.aeb_time is None:
                self.aeb_time = t
            self.latched = self.plain_latches  # see command
        brakes = self.brakes
        if brakes:
            brakes.append(brake)
            brake = brakes.popleft()
        return throttle, brake, steer

    def _step(
        self, ego: Any, speed: float, t: float, detections: Any, image: Any, objects: Any = None
    ) -> tuple[float, float, float, bool | None]:
        """The AV stack's step through its protocol: (throttle, brake, steer, True once
        its ``Control.info["aeb"]`` says the AEB latched, False while
        ``Control.info["aeb_active"]`` says an AEB that will release brakes, else None)."""
        obs = Observation(t, EgoState(ego.x, ego.y, ego.yaw, speed, t), detections, image, objects)
        ctrl = self.stack.step(obs)
        info = ctrl.info
        fired = None
        if info:
            fired = True if info.get("aeb") else (False if info.get("aeb_active") else None)
        return ctrl.throttle, ctrl.brake, ctrl.steer, fired
