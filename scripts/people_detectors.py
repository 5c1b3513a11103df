"""Measure two offline people detectors on colour frames (decision 0042): OpenCV's default HOG people detector and
MediaPipe's legacy pose solution, whose models ship inside its wheel. Neither is a dependency of bim2rdt.

    # 1. with the project's venv: the colour images of a recorded bag (``bim2rdt demo --targets 2 --record``) and of
    #    the real recordings in ../shared/data/sensors, as PNGs
    python scripts/people_detectors.py dump out/run /tmp/frames --sensors ../shared/data/sensors
    # 2. in a scratch venv (mediapipe 0.10.21 needs numpy<2, protobuf<5 and its own OpenCV; HOG needs OpenCV 4.x,
    #    or opencv-contrib 5.x): each image's boxes (x0, y0, x1, y1, score) and milliseconds
    python scripts/people_detectors.py measure /tmp/frames hog
    python scripts/people_detectors.py measure /tmp/frames mediapipe --confidence 0.5

The scratch venvs measured (decision 0042): ``pip install --no-deps mediapipe==0.10.21`` then ``pip install
"numpy<2" "protobuf>=4.25.3,<5" absl-py attrs flatbuffers "opencv-contrib-python-headless<4.11" matplotlib pillow``
(HOG of OpenCV 4.10 and MediaPipe); ``pip install numpy==2.4.6 opencv-contrib-python-headless==5.1.0.95 pillow``
(HOG of OpenCV 5's contrib build).

The measure step imports nothing of bim2rdt, so it runs where bim2rdt's numpy 2 cannot.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from PIL import Image


def dump(bag: Path, out: Path, sensors: Path | None) -> None:
    """Write every colour frame of ``bag`` (``demo_N.png``) and of the real recordings under ``sensors``
    (``real_*.png``: office1, TUM, the PCL grabber frames, the Azure Kinect MKV's colour track) to ``out``."""
    from bim2rdt.sources import open_source

    out.mkdir(parents=True, exist_ok=True)
    for index, frame in enumerate(open_source(bag)):
        Image.fromarray(np.asarray(frame.rgb)).save(out / f"demo_{index}.png")
    if sensors is None:
        return
    import av
    import tifffile

    Image.open(sensors / "tum" / "TUM_color.png").convert("RGB").save(out / "real_tum.png")
    for path in sorted((sensors / "pcl" / "grabber").glob("*_rgb.tiff")):
        Image.fromarray(tifffile.imread(path)[..., :3]).save(out / f"real_grabber_{path.stem[15:24]}.png")
    office = next(iter(open_source(sensors / "pcl" / "office1.pcd")))
    Image.fromarray(np.asarray(office.rgb)).save(out / "real_office1.png")
    with av.open(str(sensors / "azure_kinect" / "recording.mkv")) as container:
        for index, image in enumerate(container.decode(container.streams.video[0])):
            Image.fromarray(image.to_ndarray(format="rgb24")).save(out / f"real_mkv_{index}.png")


def hog_detector():
    """``detect(rgb) -> [(x0, y0, x1, y1, score)]``: OpenCV's default people detector (winStride 8, scale 1.05)."""
    import cv2

    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())

    def detect(rgb: np.ndarray) -> list[tuple]:
        rects, weights = hog.detectMultiScale(rgb[..., ::-1].copy(), winStride=(8, 8), padding=(8, 8), scale=1.05)
        return [(int(x), int(y), int(x + w), int(y + h), round(float(s), 2))
                for (x, y, w, h), s in zip(rects, np.ravel(weights))]
    return detect


def mediapipe_detector(confidence: float):
    """``detect(rgb) -> [(x0, y0, x1, y1, mean visibility)]``: MediaPipe Pose (model_complexity 1, the full
    landmark model its wheel ships; 0 and 2 would be downloaded), the box of its landmarks visible at 0.5."""
    from mediapipe.python.solutions import pose

    solution = pose.Pose(static_image_mode=True, model_complexity=1, min_detection_confidence=confidence)

    def detect(rgb: np.ndarray) -> list[tuple]:
        found = solution.process(rgb)
        if not found.pose_landmarks:
            return []
        marks = [(m.x * rgb.shape[1], m.y * rgb.shape[0], m.visibility) for m in found.pose_landmarks.landmark]
        seen = np.array([(x, y) for x, y, v in marks if v > 0.5]).reshape(-1, 2)
        score = round(float(np.mean([v for *_, v in marks])), 2)
        if not len(seen):
            return [(None, None, None, None, score)]
        return [(*(int(c) for c in seen.min(axis=0)), *(int(c) for c in seen.max(axis=0)), score)]
    return detect


def measure(folder: Path, detector: str, confidence: float) -> None:
    """Print each PNG's detections and the milliseconds the detector took on it (after one warm-up call)."""
    detect = hog_detector() if detector == "hog" else mediapipe_detector(confidence)
    detect(np.zeros((480, 640, 3), np.uint8))
    for path in sorted(folder.glob("*.png")):
        rgb = np.ascontiguousarray(np.asarray(Image.open(path).convert("RGB")))
        start = time.perf_counter()
        boxes = detect(rgb)
        print(f"{detector} {path.name:28s} {1000 * (time.perf_counter() - start):6.0f} ms {boxes}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    steps = parser.add_subparsers(dest="step", required=True)
    dumping = steps.add_parser("dump")
    dumping.add_argument("bag", type=Path)
    dumping.add_argument("out", type=Path)
    dumping.add_argument("--sensors", type=Path)
    measuring = steps.add_parser("measure")
    measuring.add_argument("folder", type=Path)
    measuring.add_argument("detector", choices=("hog", "mediapipe"))
    measuring.add_argument("--confidence", type=float, default=0.5)
    args = parser.parse_args()
    if args.step == "dump":
        dump(args.bag, args.out, args.sensors)
    else:
        measure(args.folder, args.detector, args.confidence)


if __name__ == "__main__":
    main()
