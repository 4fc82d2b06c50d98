"""Image detectors: the ``Detector`` interface and the SSD-MobileNetV2 (OIDv4) implementation.

The TFLite model outputs raw tensors: box regressions (1, 1917, 4) and class logits
(1, 1917, 24). Everything after the network -- anchors, box decoding, sigmoid scores and
non-maximum suppression -- is done here in numpy so it is inspectable and deterministic.
"""

from __future__ import annotations

import abc
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from sitcov.errors import MissingExtraError, SitcovError
from sitcov.perception._anchors import decode_boxes, ssd_anchors
from sitcov.perception._base import Detection
from sitcov.perception._models import labels_path, model_path
from sitcov.perception._nms import per_class_nms

#: Input side of the network [px].
INPUT_SIZE = 300
#: The Open Images V4 label map inside the npm package (index 0 is background).
OIDV4_LABELS = (
    "???", "Bicycle", "Boot", "Laptop", "Person", "Chair", "Cattle", "Desk", "Cat",
    "Computer mouse", "Computer monitor", "Box", "Mug", "Coffee cup", "Stationary bicycle",
    "Table", "Bottle", "High heels", "Vehicle", "Footwear", "Dog", "Book", "Camera", "Car",
)  # fmt: skip
#: Our output label -> the model's classes that count as it: vehicles only.
CAR_CLASSES: Mapping[str, tuple[str, ...]] = {"car": ("Car", "Vehicle")}
#: Every road user (the default): the OIDv4 map of this model has one person class
#: ("Person"; no Man/Woman/Boy/Girl/Human body here) and "Bicycle". "Stationary bicycle"
#: (an exercise bike) and the clothing classes (Footwear, Boot, High heels) are parts or
#: look-alikes, not road users, so they are not mapped. docs/camera.md#classes.
ROAD_USER_CLASSES: Mapping[str, tuple[str, ...]] = {
    "car": ("Car", "Vehicle"),
    "person": ("Person",),
    "bicycle": ("Bicycle",),
}
#: The letterbox's grey (128) as a network input, computed as the image pixels are.
_PAD = np.full(3, 128.0, dtype=np.float32) * (2.0 / 255.0) - 1.0
_PADDED = np.ascontiguousarray(np.broadcast_to(_PAD, (1, INPUT_SIZE, INPUT_SIZE, 3)))
_PADDED.flags.writeable = False
#: Every 8-bit pixel value as a network input (the same float32 operations as on a
#: whole frame, ``v * (2 / 255) - 1``: one table lookup per value instead).
_INPUT_OF = np.arange(256, dtype=np.float32) * (2.0 / 255.0) - 1.0
_INPUT_OF.flags.writeable = False
#: The class label a detector reports for each ActorView kind (a cyclist counts as found
#: when either its bicycle or its rider is detected).
KIND_LABELS: Mapping[str, tuple[str, ...]] = {
    "car": ("car",),
    "truck": ("car",),
    "pedestrian": ("person",),
    "cyclist": ("bicycle", "person"),
}
#: The detector labels whose boxes a kind's PEM detection stands for: the per-class PEM
#: is fitted to the top score among the boxes of these labels on the road user, and its
#: detection carries the first. A cyclist's PEM detection is its rider (``person``): in
#: camera mode the reference AEB brakes on the rider's person box in 45 of 45 cyclist runs
#: that braked, and the rider's box, not the bicycle's, is the one tall enough for the
#: distance test (docs/pem.md, "The cyclist's detection is its rider").
PEM_LABELS: Mapping[str, tuple[str, ...]] = {
    "car": ("car",),
    "truck": ("car",),
    "pedestrian": ("person",),
    "cyclist": ("person",),
    "bicycle": ("bicycle",),
}
#: The detections the PEM gives a road user of each kind, each scored by its own entry of
#: the per-class file (``pem_classes.yaml``): a cyclist's rider (entry ``cyclist``) and its
#: bicycle (entry ``bicycle``), as the SSD reports both (docs/pem.md, "The cyclist's two
#: detections"). A part the file has no entry for is not given (a file written before the
#: bicycle's entry gives the rider alone, as before). Kinds not listed give one detection.
PEM_PARTS: Mapping[str, tuple[str, ...]] = {
    "pedestrian": ("pedestrian",),
    "cyclist": ("cyclist", "bicycle"),
}
#: The road-user kind of each per-class entry (the situations its frames are recorded in).
PART_KIND: Mapping[str, str] = {
    "pedestrian": "pedestrian",
    "cyclist": "cyclist",
    "bicycle": "cyclist",
}


class Detector(abc.ABC):
    """Finds objects in an RGB image.

    Implement ``__call__`` to plug another model into the camera path: it receives an
    HxWx3 uint8 frame and returns detections with boxes in that frame's pixels.
    """

    @abc.abstractmethod
    def __call__(self, image: np.ndarray) -> tuple[Detection, ...]:
        """Detections in ``image`` (HxWx3 uint8), best score first."""

    def close(self) -> None:  # noqa: B027
        """Release resources."""


def _load_labels(model: Path) -> tuple[str, ...]:
    path = labels_path(model)
    if path.is_file():
        names = tuple(line.strip() for line in path.read_text().splitlines() if line.strip())
        if len(names) == len(OIDV4_LABELS):
            return names
    return OIDV4_LABELS


class SSDDetector(Detector):
    """SSD-MobileNetV2 trained on Open Images V4, run by ai-edge-litert on one thread.

    Args:
        model: path to the ``.tflite`` file (default: the fetched model, see
            :func:`sitcov.perception.model_path`).
        min_score: detections below this score [0, 1] are dropped. Low by default so the
            AEB's own threshold (0.5, or 0.95 with fault f1) is what decides.
        iou_threshold: NMS overlap above which the lower-scoring box is suppressed.
        classes: output label -> model class names merged into it (default
            :data:`ROAD_USER_CLASSES`: Car and Vehicle count as ``"car"``, Person as
            ``"person"``, Bicycle as ``"bicycle"``). NMS runs within each output label, so
            a rider and their bicycle both survive.
        max_detections: at most this many detections per frame.

    Raises:
        MissingExtraError: ai-edge-litert is not installed.
        ModelNotFoundError: the model has not been fetched.
    """

    def __init__(
        self,
        model: str | os.PathLike[str] | None = None,
        *,
        min_score: float = 0.3,
        iou_threshold: float = 0.5,
        classes: Mapping[str, Sequence[str]] | None = None,
        max_detections: int = 20,
    ) -> None:
        try:
            from ai_edge_litert.interpreter import Interpreter
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise MissingExtraError("the camera detector", "camera", "ai-edge-litert") from exc
        self.model = model_path(model)
        self.min_score = float(min_score)
        self.iou_threshold = float(iou_threshold)
        self.max_detections = int(max_detections)
        self._interp = Interpreter(model_path=str(self.model), num_threads=1)
        self._interp.allocate_tensors()
        inp = self._interp.get_input_details()[0]
        outs = {d["name"]: d for d in self._interp.get_output_details()}
        self._in_index = inp["index"]
        if tuple(inp["shape"]) != (1, INPUT_SIZE, INPUT_SIZE, 3):
            raise SitcovError(f"{self.model}: expected input 1x300x300x3, got {inp['shape']}")
        try:
            self._box_index = outs["raw_outputs/box_encodings"]["index"]
            self._cls_index = outs["raw_outputs/class_predictions"]["index"]
        except KeyError as exc:
            raise SitcovError(f"{self.model}: missing output tensor {exc}") from exc
        self.anchors = ssd_anchors()
        #: the last image detected in (a copy) and its detections (see __call__)
        self._last: tuple[np.ndarray, tuple[Detection, ...]] | None = None
        names = _load_labels(self.model)
        wanted = ROAD_USER_CLASSES if classes is None else classes
        self._groups: list[tuple[str, list[int]]] = []
        for label, members in wanted.items():
            idx = [names.index(m) for m in members if m in names]
            if not idx:
                raise SitcovError(f"none of {list(members)} is a class of {self.model.name}")
            self._groups.append((label, idx))

    @staticmethod
    def letterbox(shape: tuple[int, ...]) -> tuple[float, float, float]:
        """Scale [input px per image px] and x/y padding [input px] of the letterbox."""
        h, w = shape[:2]
        scale = INPUT_SIZE / max(h, w)
        return scale, 0.5 * (INPUT_SIZE - w * scale), 0.5 * (INPUT_SIZE - h * scale)

    @classmethod
    def preprocess(cls, image: np.ndarray) -> np.ndarray:
        """Letterbox to 300x300 (aspect kept, grey padding) and scale pixels to [-1, 1].

        Squashing a 16:9 frame to a square distorts cars enough to cost ~0.2 in score;
        padding keeps their shape, as the network saw them in training. The frame is
        resized by Pillow (bilinear) and written into a padded buffer: the same values as
        pasting it onto a grey 300x300 canvas, without converting the padding each frame;
        its pixels are converted by a 256-entry table (:data:`_INPUT_OF`).
        """
        from PIL import Image

        img = Image.fromarray(np.ascontiguousarray(image[..., :3]))
        scale, px, py = cls.letterbox(image.shape)
        size = (max(1, round(img.width * scale)), max(1, round(img.height * scale)))
        small = np.asarray(img.resize(size, Image.BILINEAR), dtype=np.uint8)
        out = _PADDED.copy()  # a memcpy; filling from the 3-vector is 20x slower
        x, y = round(px), round(py)
        if x == 0 and size[0] == INPUT_SIZE:  # whole rows: a contiguous window
            np.take(_INPUT_OF, small, out=out[0, y : y + size[1]])
        else:
            out[0, y : y + size[1], x : x + size[0]] = _INPUT_OF[small]
        return out

    def raw(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The network's raw outputs for ``image``: (1917, 4) boxes, (1917, 24) logits."""
        self._interp.set_tensor(self._in_index, self.preprocess(image))
        self._interp.invoke()
        # get_tensor returns copies: the arrays stay valid after the next invoke.
        boxes = self._interp.get_tensor(self._box_index)[0]
        logits = self._interp.get_tensor(self._cls_index)[0]
        return boxes, logits

    def _scores(self, logits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per output label and anchor, the best member class's score; flattened label-major
        with the label index of each entry. The sigmoid is monotonic, so it is taken of the
        best logit: exactly the max of the members' sigmoid scores, for a fraction of the
        exponentials (only the mapped classes' columns)."""
        best = np.concatenate([logits[:, idx].max(axis=1) for _, idx in self._groups])
        scores = 1.0 / (1.0 + np.exp(-best.astype(np.float64)))
        return scores, np.repeat(np.arange(len(self._groups)), len(logits))

    def __call__(self, image: np.ndarray) -> tuple[Detection, ...]:
        """Detections in ``image``; boxes in its pixels, clipped to it.

        The network is deterministic, so an image equal to the previous one, pixel for
        pixel, gets the previous detections without running it again (camera mode hands
        a stopped ego that sees nothing move the same frame again: docs/camera.md)."""
        last = self._last
        if last is not None and _same_pixels(last[0], image):
            return last[1]
        out = self._detect(image)
        self._last = (np.array(image, copy=True), out)
        return out

    def _detect(self, image: np.ndarray) -> tuple[Detection, ...]:
        """:meth:`__call__` without the repeated-frame shortcut."""
        h, w = image.shape[:2]
        raw_boxes, logits = self.raw(image)
        scores, groups = self._scores(logits)
        cand = np.flatnonzero(scores >= self.min_score)
        if cand.size == 0:
            return ()
        anchor_idx = cand % len(logits)
        boxes = decode_boxes(raw_boxes[anchor_idx], self.anchors[anchor_idx])
        scale, px, py = self.letterbox(image.shape)
        boxes = (boxes * INPUT_SIZE - np.array([px, py, px, py])) / scale
        boxes = np.clip(boxes, 0.0, np.array([w, h, w, h], dtype=np.float64))
        keep = per_class_nms(boxes, scores[cand], groups[cand], self.iou_threshold)
        out = []
        for k in keep[: self.max_detections]:
            x0, y0, x1, y1 = (float(v) for v in boxes[k])
            if x1 - x0 < 1.0 or y1 - y0 < 1.0:
                continue
            label = self._groups[int(groups[cand[k]])][0]
            out.append(Detection(box=(x0, y0, x1, y1), score=float(scores[cand[k]]), label=label))
        return tuple(out)


def _same_pixels(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two images are equal pixel for pixel (every 16th row first: frames of a
    moving camera differ there, so most comparisons stop after a sixteenth of the work)."""
    return (
        a.shape == b.shape
        and a.dtype == b.dtype
        and np.array_equal(a[::16], b[::16])
        and np.array_equal(a, b)
    )
