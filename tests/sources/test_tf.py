"""The TF buffer's quaternion arithmetic, against scipy's: a quaternion to a matrix, and interpolation between
two samples on the shorter arc (what tf2 does), including a sample pair on opposite hemispheres."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from bim2rdt.sources.tf import TfBuffer, matrix, slerp


def test_a_quaternion_gives_scipys_rotation_matrix_and_the_translation():
    q = Rotation.from_euler("xyz", [10.0, -35.0, 120.0], degrees=True).as_quat()
    T = matrix((1.0, 2.0, 3.0), 2.0 * q)  # not unit: normalised
    assert np.allclose(T[:3, :3], Rotation.from_quat(q).as_matrix()) and np.allclose(T[:3, 3], (1.0, 2.0, 3.0))
    assert np.allclose(T[3], (0.0, 0.0, 0.0, 1.0))


@pytest.mark.parametrize("s", [0.0, 0.25, 0.5, 0.9, 1.0])
@pytest.mark.parametrize("flip", [False, True])
def test_slerp_matches_scipys_on_the_shorter_arc(s, flip):
    q0 = Rotation.from_euler("z", 10.0, degrees=True).as_quat()
    q1 = Rotation.from_euler("zy", [70.0, 20.0], degrees=True).as_quat() * (-1.0 if flip else 1.0)
    expected = Slerp([0.0, 1.0], Rotation.from_quat([q0, q1]))([s])[0].as_matrix()
    assert np.allclose(Rotation.from_quat(slerp(q0, q1, s)).as_matrix(), expected, atol=1e-9)


def test_a_lookup_between_two_samples_interpolates_translation_and_rotation():
    buffer = TfBuffer(tolerance=0.02, max_gap=2.0)
    buffer.add("odom", "base_link", (0.0, 0.0, 0.0), Rotation.from_euler("z", 0.0, degrees=True).as_quat(), 1.0)
    buffer.add("odom", "base_link", (2.0, 0.0, 0.0), Rotation.from_euler("z", 90.0, degrees=True).as_quat(), 2.0)
    T = buffer.lookup("odom", "base_link", 1.25)
    assert np.allclose(T[:3, 3], (0.5, 0.0, 0.0))
    assert np.isclose(Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)[2], 22.5)


def test_forgetting_is_linear_in_the_frames_a_recording_names():
    """20,000 frames named once each, forgotten after every message as the bag reader does (main visited every
    edge each time: 2e8 visits, 67 s in a bag); stale edges go, so memory stays flat too."""
    import time

    from bim2rdt.sources import tf

    buffer = tf.TfBuffer()
    visited = []
    real_bisect = tf.bisect.bisect_left
    started = time.process_time()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tf.bisect, "bisect_left", lambda *a, **k: visited.append(1) or real_bisect(*a, **k))
        for i in range(20_000):
            buffer.add("map", f"frame_{i}", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), float(i))
            buffer.add("map", "base_link", (float(i), 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), float(i))
            buffer.forget_before(i - 30.0)
            if len(visited) > 200_000:
                break  # quadratic: stop early, the assertion below fails
    assert time.process_time() - started < 10.0  # generous: well under 1 s here
    assert len(visited) < 200_000  # only the one long edge is trimmed; main: 2e8
    assert len(buffer.frames) < 40  # the last 30 s of frames, base_link and map
    assert isinstance(buffer.lookup("map", "base_link", 19_999.0), np.ndarray)
    assert buffer.lookup("map", "frame_19999", 19_999.0)[0, 3] == 0.0


def test_a_lookup_through_a_cycle_says_so():
    buffer = TfBuffer()
    buffer.add("a", "b", (0, 0, 0), (0, 0, 0, 1), None)
    buffer.add("b", "a", (0, 0, 0), (0, 0, 0, 1), None)
    buffer.add("a", "camera", (0, 0, 0), (0, 0, 0, 1), None)
    assert buffer.cycle("camera") == ["a", "b", "a"]
    assert buffer.lookup("b", "camera", 0.0) == "TF cycle a -> b -> a"
