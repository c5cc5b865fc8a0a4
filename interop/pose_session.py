"""The eye-in-hand session the pose_node checks publish, and what its poses must be.

`stereocal synth --scene handeye-in-hand` renders the session (a 1024x768 mono8 camera
on a robot's tool looking at a fixed 9x6 chessboard of 30 mm squares: a bag with
/camera/image_raw and /camera/camera_info, stamps equal, and ground_truth.json with
every frame's `camera_from_target`); `stereocal pose --json` on the same bag gives the
poses the node must publish, as the offline command and the node judge a frame with the
same code. A pose is compared as a rotation matrix and a translation in metres.
"""

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from bag_images import messages

FRAMES, SEED = 8, 7
IMAGE_RAW, CAMERA_INFO = "/camera/image_raw", "/camera/camera_info"
#: Largest distance of a published pose from the session's ground truth.
TRUTH_DEGREES, TRUTH_MM = 0.05, 0.5
#: Largest difference of a published pose from `stereocal pose --json`'s, per entry of
#: the rotation matrix and per coordinate of the translation (metres).
OFFLINE_TOLERANCE = 1e-9


@dataclass
class Session:
    """A synthesized session: its bag, the board, and per image stamp ((sec, nanosec))
    the ground truth and `stereocal pose --json`'s record."""

    bag: Path
    board: dict
    truth: dict
    offline: dict

    def frames(self):
        """The bag's (image, camera_info) pairs in stamp order, as `rosbags` messages."""
        images, infos = {}, {}
        for topic, msg in messages(self.bag, (IMAGE_RAW, CAMERA_INFO)):
            stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
            (images if topic == IMAGE_RAW else infos)[stamp] = msg
        return [(images[s], infos[s]) for s in sorted(images) if s in infos]

    def size_parameters(self):
        """The node's `size` and `square` for the session's board."""
        return (f"{self.board['inner_corners_cols']}x{self.board['inner_corners_rows']}",
                float(self.board["square_size_m"]))


def synthesize(stereocal, out, frames=FRAMES, seed=SEED):
    """Renders the session into `out` and runs `stereocal pose --json` on it; raises
    RuntimeError, with what the command printed, when one of them fails."""
    out = Path(out)
    run = subprocess.run([str(stereocal), "synth", "--scene", "handeye-in-hand", "--frames",
                          str(frames), "--seed", str(seed), "--out", str(out / "scene")],
                         capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"stereocal synth failed:\n{run.stderr}")
    truth = json.loads((out / "scene" / "ground_truth.json").read_text())
    session = Session(bag=out / "scene" / "bag", board=truth["board"], truth={}, offline={})
    size, square = session.size_parameters()
    run = subprocess.run([str(stereocal), "pose", "--bag", str(session.bag), "--out",
                          str(out / "poses"), "--size", size, "--square", str(square), "--json"],
                         capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"stereocal pose failed:\n{run.stderr}")
    records = json.loads(run.stdout)["frames"]
    session.truth = {(f["stamp"]["sec"], f["stamp"]["nanosec"]):
                     f["views"][0]["camera_from_target"] for f in truth["frames"]}
    for stamp in session.truth:
        seconds = stamp[0] + stamp[1] * 1e-9
        # --json stamps are seconds as a double: the nearest record, well within a frame.
        record = min(records, key=lambda r: abs(r["stamp"] - seconds), default=None)
        if record is not None and abs(record["stamp"] - seconds) < 1e-6:
            session.offline[stamp] = record
    return session


def rotation_of(q):
    """The rotation matrix of a unit quaternion with fields x, y, z, w."""
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def quaternion_norm(q):
    return float(np.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w))


def truth_error(rotation, translation, truth):
    """(degrees, millimetres) from a ground-truth `camera_from_target` record."""
    r_true = np.reshape(truth["rotation_row_major"], (3, 3))
    angle, _ = cv2.Rodrigues(np.asarray(rotation) @ r_true.T)
    offset = np.linalg.norm(np.subtract(translation, truth["translation_m"]))
    return float(np.degrees(np.linalg.norm(angle))), float(offset * 1e3)


def offline_difference(rotation, translation, record):
    """Largest difference from `stereocal pose --json`'s record of the frame: rotation
    matrix entries and translation coordinates (metres)."""
    pose = record["camera_from_target"]
    return max(float(np.abs(np.ravel(rotation) - pose["rotation"]).max()),
               float(np.abs(np.subtract(translation, pose["translation"])).max()))
