"""The reference stack acts on every road user class; F4's AEB ignores pedestrians."""

from __future__ import annotations

import dataclasses

import pytest

from sitcov.av import ReferenceStack, aeb_test
from sitcov.av._aeb import CLASS_SIZE
from sitcov.hyperspace import Situation
from sitcov.perception import PEMSensor
from sitcov.perception._base import Detection

WIDTH = 800.0
ARGS = (WIDTH, 0.5, (0.05, 0.98), 0.6)


def test_a_close_pedestrian_passes_by_its_height_not_its_width() -> None:
    tall = (380.0, 100.0, 420.0, 400.0)  # 40 px wide, 300 px tall, centred
    assert aeb_test(Detection(tall, 0.9, "person"), *ARGS, ("car", "person"))
    # the same box judged by its width (the paper's car test) is far away
    assert not aeb_test(Detection(tall, 0.9, "car"), *ARGS, ("car", "person"))
    # a distant pedestrian (60 px tall) does not pass
    small = (395.0, 200.0, 405.0, 260.0)
    assert not aeb_test(Detection(small, 0.9, "person"), *ARGS, ("car", "person"))


def test_person_and_cyclist_heights_are_scaled_to_a_cars_width() -> None:
    assert CLASS_SIZE["car"] == ("width", 1.0)
    assert CLASS_SIZE["person"][0] == CLASS_SIZE["bicycle"][0] == "height"
    assert CLASS_SIZE["person"][1] == pytest.approx(1.61 / 1.75)
    assert CLASS_SIZE["bicycle"][1] == pytest.approx(1.61 / 1.7)


def test_classes_not_listed_are_ignored_and_the_label_alone_still_works() -> None:
    box = (300.0, 100.0, 500.0, 400.0)
    assert not aeb_test(Detection(box, 0.9, "person"), *ARGS, ("car",))
    assert aeb_test(Detection(box, 0.9, "car"), *ARGS)  # the old signature: label "car"
    assert ReferenceStack(params={"classes": ["car"]}).config()["params"]["classes"] == ["car"]


def test_f4_ignores_pedestrians_only() -> None:
    f4 = ReferenceStack(fault="f4")
    assert "person" not in f4.params["classes"] and "bicycle" in f4.params["classes"]
    assert "person" in ReferenceStack().params["classes"]


class PersonPEM(PEMSensor):
    """The PEM with every detection labelled by the kind of the (single) actor in view."""

    LABELS = {"car": "car", "pedestrian": "person", "cyclist": "bicycle"}

    def detect(self, ego, actors, conditions, rng):
        dets = super().detect(ego, actors, conditions, rng)
        if not actors:
            return dets
        label = self.LABELS[actors[0].kind]
        return tuple(dataclasses.replace(d, label=label) for d in dets)


def test_the_reference_stack_brakes_for_a_pedestrian_and_f4_does_not() -> None:
    from sitcov.sim.embedded import EmbeddedBackend

    backend = EmbeddedBackend(sensor=PersonPEM())
    # from the far kerb (XBR): the pedestrian crosses the oncoming lane first, in view of
    # the camera; from the near kerb (XBL), at a walking speed (issue 23), it steps into the
    # ego's lane about 2 s before the ego, too late for the AEB's box
    values = {"intsit": {"ego": "L-B", "ov": "XBR", "conflict": "p", "kind": "pedestrian"}}
    s = Situation(bins={"intsit": "ped"}, values=values)
    nominal = [backend.run(s, ReferenceStack(), seed=k) for k in range(4)]
    faulty = [backend.run(s, ReferenceStack(fault="f4"), seed=k) for k in range(4)]
    assert all(o.aeb_fired for o in nominal)
    assert sum(o.collision for o in nominal) <= 1
    assert not any(o.aeb_fired for o in faulty)
    assert all(o.metrics["collision_kind"] == "pedestrian" for o in faulty)
