"""The OVs' controllers: a timed car's one-call step equals the law plus the steering."""

from __future__ import annotations

import math
from types import SimpleNamespace

from sitcov.sim._adversary import AdversaryParams
from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._bodies import body_spec, make_body
from sitcov.sim.embedded._controllers import TimingController, lateral_controller
from sitcov.sim.embedded._path import Path

CURVE = Path.from_points([(float(x), 0.004 * x * x) for x in range(0, 101)])


def _car() -> Actor:
    x, y, h = CURVE.point_at(0.0)
    return Actor("ov", "car", body_spec("car"), make_body("car", x, y, h), CURVE)


def test_a_timed_car_steps_as_the_law_and_its_steering_do() -> None:
    """Over a whole approach (wait, regulate, switch to cruise) the car's command, phase and
    switch time equal those of the general path (AdversaryController.command, then
    lateral_controller at the law's look-ahead), bit for bit."""
    params = AdversaryParams(switch_distance=15.0)
    fast, slow = TimingController(params, 60.0, 50.0), TimingController(params, 60.0, 50.0)
    car_a, car_b = _car(), _car()
    steer = lateral_controller(car_b)
    ego = SimpleNamespace(s=0.0)
    world = SimpleNamespace(ego=ego, ego_speed=0.0, t=0.0, dt=0.05)
    phases = []
    for k in range(400):
        world.t, world.ego_speed = 0.05 * k, (0.0 if k < 20 else min(8.0, 0.1 * k))
        ego.s += 0.05 * world.ego_speed
        cmd = fast.command(car_a, world)
        speed = car_b.body.speed
        law = slow.law
        thr, brk = law.command(60.0 - ego.s, world.ego_speed, 50.0 - car_b.s, speed)
        if slow.switch_time is None and law.phase == "cruise":
            slow.switch_time = world.t
        want = (thr, brk, steer(max(params.lookahead_min, params.lookahead_time * speed)))
        assert repr(cmd) == repr(want), k
        assert fast.law.phase == law.phase
        for car in (car_a, car_b):
            car.move(*cmd, 1.0, 0.0, 0.05)
        phases.append(law.phase)
    assert {"wait", "regulate", "cruise"} <= set(phases)
    assert fast.switch_time == slow.switch_time is not None
    assert math.isclose(fast.brake, cmd[1])
