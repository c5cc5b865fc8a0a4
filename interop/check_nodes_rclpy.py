"""Real ROS 2 tests every stereocal node: rclpy on Fast DDS, as users' robots run it.

rclpy from the ROS 2 Kilted wheels on rmw_fastrtps_cpp (the default middleware of a ROS 2
install), on a ROS domain leased for this run, starts each node as its own process in a
namespace with remaps and checks, node by node, what a ROS 2 user and the C++/Python
nodes around it would see:

- discovery: the node's name and namespace are in the ROS graph (`ros2 node list`);
- graph: its publishers, subscribers, services and service clients, with their types,
  are exactly those it documents, and its topics are in `ros2 topic list -t` (pose_node's
  /tf by its type's name: there is no tf2_msgs wheel for rclpy, and
  interop/check_pose_cyclone.py receives /tf with Cyclone DDS);
- QoS: a default reliable subscriber (depth 10) and a `qos_profile_sensor_data`
  best-effort subscriber both receive its output (images; pose_node's target_pose),
  published from rclpy's input;
- content: rectify_node's image_rect equals OpenCV's initUndistortRectifyMap + remap
  within 1 grey level (bilinear, then nearest after `interpolation` is set to 0 while it
  runs), and with `image_transport: compressed`, fed PNG (mono8, rgb8) and JPEG
  CompressedImage on `image_raw/compressed`, equals OpenCV's remap of the image (PNG,
  within 1) or of OpenCV's imdecode of the JPEG (within 2), logging a truncated JPEG and
  going on; its image_rect/compressed, while subscribed, is JPEG by default and PNG once
  `image_rect.compressed.format` is set to png, and OpenCV's imdecode of it equals
  image_rect (PNG) or differs from it on average no more than OpenCV's own JPEG of it at
  the same quality does (within 10 %); camera_node on its test pattern (CI has no video
  device) in MJPEG publishes each frame's JPEG as it came on image_raw/compressed and the
  image_raw of the same stamp within 2 grey levels of OpenCV's imdecode of that JPEG,
  with a camera_info of the same stamp; calibrate_node, fed a synthesized stereo session (`stereocal synth`) from
  rclpy, calibrates on `~/calibrate` within 0.2 px (fx, fy, cx, cy), 0.1 degree and 1 mm
  (right_from_left) of the session's ground truth, and `~/commit` writes camera_info
  YAML that PyYAML reads back with the same numbers, while rclpy's set_camera_info
  server receives the same calibration; pose_node, fed a synthesized eye-in-hand session
  (image + camera_info of equal stamps) from rclpy, publishes every frame's target_pose
  with the image's stamp and frame_id, within 0.05 degree and 0.5 mm of the ground truth
  and equal (1e-9) to `stereocal pose --json` on the same bag, and its
  target_pose_with_covariance with the same pose and a symmetric positive semi-definite
  covariance equal to --json's; an uncalibrated camera_info (K[0] = 0) and an image
  without the target publish no pose and are counted in `~/status`'s `rejections`;
- parameters through the rcl_interfaces services, as `ros2 param` calls them: list
  (with prefixes and depth), get, get types, describe (a description for every
  parameter, ranges on every integer and double, read_only, allowed values of string
  parameters with a fixed set in `additional_constraints`), a set that takes effect, a
  set out of range or of a read-only parameter refused with a reason and changing
  nothing (pose_node, whose parameters are all read-only, also refuses to start with an
  out-of-range value), camera_node's V4L2 control `brightness` described with the
  device's range, refused out of range and brightening image_raw when set, an atomic set with one bad value changing nothing,
  `/parameter_events` naming the node and the new value after a set, and every
  parameter described in one call (a reply larger than one datagram);
- services: calibrate_node's `~/calibrate` (refused with the reason before enough
  samples, then succeeding), `~/commit`, `~/reset`; handeye_node, fed a synthesized
  eye-in-hand session (images, and the robot's PoseStamped poses standing still around
  each frame) from rclpy: `~/take_sample` and `~/compute` refused with the reason before
  any frame, a sample taken on every frame, `~/compute` equal (1e-9) to `stereocal
  handeye --json` on the same bag and within three predicted standard deviations of
  the truth, `~/save` writing the YAML PyYAML reads and report.html, `~/reset`;
  camera_node's `set_camera_info` writing the YAML PyYAML reads before it answers and
  the next camera_info carrying it, and, on a device that does not exist, `~/status`
  and /rosout saying why while it keeps trying, and `set_camera_info` to an unwritable
  camera_info_url refused with the reason;
- block matching: disparity_node with `stereo_algorithm: 0` publishes the disparity of
  every rendered pair equal to `stereocal depth --algorithm bm`'s;
- the whole stereo pipeline: both rectify nodes, disparity_node and point_cloud_node in
  one `stereocal node compose` process, fed raw (distorted) stereo frames from rclpy,
  publish the disparity and points2 of every pair equal to `stereocal rectify` then
  `stereocal depth` on the same frames;
- durability: a transient-local subscriber created after calibrate_node or pose_node
  published `~/status` still receives the last status (pose_node's with the session's
  frame counts);
- /rosout: rcl_interfaces/Log records from the node, with its logger name;
- clean shutdown: SIGTERM makes the node exit with 0, no thread of it having panicked,
  and leave the graph.

Prints the table of checks with their times and every failure's reason; exits non-zero
on any failure.

rclpy's Fast DDS asks for 8 MiB UDP socket buffers, as the nodes do for themselves: with
Fast DDS's default (the OS's 208 KiB) the 2.4 MB annotated images, which RustDDS sends
as one burst of datagrams, overflow it, and a best-effort subscriber gets none of them
(`--fastdds-socket-buffer 0` shows it).

Usage (after `cargo build --bin rectify_node --bin calibrate_node --bin pose_node
--bin handeye_node --bin disparity_node --bin point_cloud_node --bin camera_node
--bin stereocal`):
    .venv/bin/python interop/check_nodes_rclpy.py [--rectify-node PATH]
        [--calibrate-node PATH] [--pose-node PATH] [--handeye-node PATH]
        [--disparity-node PATH] [--point-cloud-node PATH] [--camera-node PATH]
        [--stereocal PATH]
        [--only rectify|calibrate|pose|handeye|disparity|point_cloud|pipeline|camera]
        [--fastdds-socket-buffer BYTES]
"""

import argparse
import array
import copy
import json
import subprocess
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import yaml
from bag_images import messages as bag_messages
from pose_session import FRAMES as POSE_FRAMES
from pose_session import (
    CAMERA_INFO, IMAGE_RAW, OFFLINE_TOLERANCE, TRUTH_DEGREES, TRUTH_MM, offline_difference,
    quaternion_norm, rotation_of, synthesize, truth_error,
)
# ros2_rclpy first: it chooses the middleware before rclpy loads one.
from rectify_scene import D, HEIGHT, K, P, R, WIDTH, opencv_rectified, pixels
from ros2_rclpy import (
    TIMEOUT_S, DomainLease, NodeProcess, Parameters, Peer, main_guard, python_value, require,
    stop_and_check,
)

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from rcl_interfaces.msg import Log, ParameterEvent, ParameterType
from rclpy.qos import (
    DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_parameter_events,
    qos_profile_rosout_default, qos_profile_sensor_data,
)
from sensor_msgs.msg import (
    CameraInfo, CompressedImage, Image, PointCloud2, PointField, RegionOfInterest,
)
from sensor_msgs.srv import SetCameraInfo
from std_msgs.msg import Header, String
from stereo_msgs.msg import DisparityImage

ROOT = Path(__file__).resolve().parent.parent
RELIABLE = QoSProfile(depth=10)
STATUS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: Parameters described per call when checking what the descriptors say.
DESCRIBE_BATCH = 4
INTEGER, DOUBLE = ParameterType.PARAMETER_INTEGER, ParameterType.PARAMETER_DOUBLE
TYPE_OF = {bool: ParameterType.PARAMETER_BOOL, int: INTEGER, float: DOUBLE,
           str: ParameterType.PARAMETER_STRING}


def stamp_of(msg):
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


def header(stamp, frame_id):
    return Header(stamp=Time(sec=stamp[0], nanosec=stamp[1]), frame_id=frame_id)


def image_msg(stamp, frame_id, raw, encoding):
    height, width = raw.shape[:2]
    return Image(header=header(stamp, frame_id), height=height, width=width, encoding=encoding,
                 is_bigendian=0, step=raw.strides[0], data=array.array("B", raw.tobytes()))


def graph_check(peer, name, namespace, expected):
    """The node's endpoints by kind ({kind: {topic: [types]}}) equal `expected`, and its
    topics are in the graph's topic list with the same types."""
    def mismatches():
        try:
            got = peer.entities_of(name, namespace)
        except Exception as e:  # the graph may not know the node's endpoints yet
            return [f"{namespace}/{name}: {e}"]
        problems = []
        for kind, want in expected.items():
            have = got[kind]
            problems += [f"{kind}: missing {t} {want[t]}" for t in sorted(set(want) - set(have))]
            problems += [f"{kind}: unexpected {t} {have[t]}" for t in sorted(set(have) - set(want))]
            problems += [f"{kind}: {t} has types {have[t]}, not {want[t]}"
                         for t in sorted(set(want) & set(have)) if have[t] != sorted(want[t])]
        topics = dict(peer.node.get_topic_names_and_types())
        for kind in ("publishers", "subscribers"):
            problems += [f"topic list: {t} {topics.get(t)}, not {types}"
                         for t, types in expected[kind].items() if topics.get(t) != types]
        return problems

    last = []

    def settled():
        last[:] = mismatches()
        return not last
    # Endpoints are discovered one by one: wait until the graph shows them all.
    peer.wait_until(settled, lambda: "the documented endpoints; still: " + "; ".join(last))


def parameter_services(fqn):
    return {f"{fqn}/{service}": [f"rcl_interfaces/srv/{srv}"] for service, srv in (
        ("describe_parameters", "DescribeParameters"),
        ("get_parameter_types", "GetParameterTypes"), ("get_parameters", "GetParameters"),
        ("list_parameters", "ListParameters"), ("set_parameters", "SetParameters"),
        ("set_parameters_atomically", "SetParametersAtomically"))}


def same_value(got, want):
    if isinstance(want, float):
        return isinstance(got, float) and abs(got - want) <= 1e-12 * max(1.0, abs(want))
    return type(got) is type(want) and got == want


def common_parameter_checks(checks, label, params, documented, read_only, constraints, refuse):
    """list/get/get_types and describe of a node whose parameters are `documented`
    ({name: start-up value}), `read_only` names, and `constraints` ({name: allowed
    values}); then a set of each parameter of `refuse` (read-only), which must be
    refused."""
    with checks.check(label, "parameters: list (prefixes, depth), get, get_parameter_types"):
        names, _ = params.list()
        require(set(documented) <= set(names),
                f"list_parameters misses {sorted(set(documented) - set(names))}: {names}")
        some = sorted(documented)[:2]
        got, _ = params.list(prefixes=some, depth=1)
        require(got == some, f"list_parameters(prefixes={some}, depth=1): {got}")
        part = some[0][:-1]
        got, _ = params.list(prefixes=[part])
        require(got == [], f"prefix {part!r} matches no whole name, yet: {got}")
        got, _ = params.list(depth=1)
        flat = [n for n in names if "." not in n]
        require(got == flat, f"list_parameters(depth=1): {got}, not {flat}")
        values = params.get(list(documented))
        wrong = [f"{n}={v!r} (expected {documented[n]!r})"
                 for n, v in zip(documented, values) if not same_value(v, documented[n])]
        require(len(values) == len(documented) and not wrong, f"get_parameters: {wrong or values}")
        types = params.get_types(list(documented))
        want = [TYPE_OF[type(v)] for v in documented.values()]
        require(types == want, f"get_parameter_types: {types}, not {want}")

    with checks.check(label, "parameters: describe (descriptions, ranges, constraints)"):
        names, _ = params.list()
        types = dict(zip(names, params.get_types(names)))
        # A few names a call, so that what the descriptors say is checked apart from
        # the size of the reply (see `describe_all_check`).
        descriptors = [d for at in range(0, len(names), DESCRIBE_BATCH)
                       for d in params.describe(names[at:at + DESCRIBE_BATCH])]
        require(len(descriptors) == len(names),
                f"{len(descriptors)} descriptors for {len(names)} parameters")
        problems = []
        for name, d in zip(names, descriptors):
            if d.name != name or d.type != types[name]:
                problems.append(
                    f"{name}: descriptor of {d.name!r} type {d.type}, not {types[name]}")
            if not d.description.strip():
                problems.append(f"{name}: no description")
            if types[name] == INTEGER and not (
                    len(d.integer_range) == 1 and d.integer_range[0].step == 1
                    and d.integer_range[0].from_value <= d.integer_range[0].to_value):
                problems.append(f"{name}: integer_range {list(d.integer_range)}")
            if types[name] == DOUBLE and not (
                    len(d.floating_point_range) == 1 and d.floating_point_range[0].step == 0.0
                    and d.floating_point_range[0].from_value <= d.floating_point_range[0].to_value):
                problems.append(f"{name}: floating_point_range {list(d.floating_point_range)}")
            if name in documented and d.read_only != (name in read_only):
                problems.append(f"{name}: read_only {d.read_only}")
            missing = [v for v in constraints.get(name, []) if v not in d.additional_constraints]
            if missing:
                problems.append(f"{name}: additional_constraints {d.additional_constraints!r} "
                                f"do not name {missing}")
        require(not problems, "; ".join(problems))

    for name in refuse:
        with checks.check(label, f"parameters: set of read-only {name} refused"):
            before = documented[name]
            # A value the parameter would otherwise accept: only read-only can refuse it.
            value = OTHER_ALLOWED_VALUE.get(name, before + 1 if isinstance(before, int) else "x")
            [result] = params.set({name: value})
            require(not result.successful and result.reason.strip(),
                    f"set {name}={value!r}: successful={result.successful}, "
                    f"reason {result.reason!r}")
            [now] = params.get([name])
            require(now == before, f"{name} is {now!r} after a refused set, not {before!r}")


def describe_all_check(checks, label, params):
    """Every parameter described in one call, as `ros2 param describe NODE $(ros2 param
    list NODE)` asks: a reply that may need more than one datagram."""
    with checks.check(label, "parameters: describe all in one call"):
        names, _ = params.list()
        descriptors = params.describe(names)
        require([d.name for d in descriptors] == names,
                f"descriptors of {[d.name for d in descriptors]} for {names}")


#: Allowed values, other than the default, of string parameters with a fixed set: a set
#: of one of them can only be refused for being read-only.
OTHER_ALLOWED_VALUE = {"pattern": "charuco", "model": "rational_polynomial",
                       "setup": "eye_to_hand"}


# ---------------------------------------------------------------------------------------
# rectify_node

def camera_info_msg(stamp, k=K):
    return CameraInfo(header=header(stamp, "cam_optical"), height=HEIGHT, width=WIDTH,
                      distortion_model="plumb_bob", d=D, k=k, r=R, p=P)


class Rectify:
    """rectify_node in /cam, its image remapped from image_raw, and rclpy around it."""
    label, name, namespace = "rectify_node", "rectify_node", "/cam"
    fqn = "/cam/rectify_node"

    def __init__(self, peer, binary):
        self.peer = peer
        node = peer.node
        self.image_pub = node.create_publisher(Image, "/cam/image_raw", RELIABLE)
        self.info_pub = node.create_publisher(CameraInfo, "/cam/camera_info", RELIABLE)
        self.reliable = peer.subscribe(Image, "/cam/image_rect", RELIABLE)
        self.sensor = peer.subscribe(Image, "/cam/image_rect", qos_profile_sensor_data)
        self.compressed = peer.subscribe(CompressedImage, "/cam/image_rect/compressed", RELIABLE)
        self.events = peer.subscribe(ParameterEvent, "/parameter_events",
                                     qos_profile_parameter_events)
        self.process = NodeProcess(
            [binary, "--ros-args", "-r", "__ns:=/cam", "-r", "image:=image_raw"], peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)
        self.sent = 0

    def send(self, raw, k=K):
        """Publishes a frame and its camera_info with a new stamp; returns the stamp."""
        self.sent += 1
        stamp = (200, self.sent * 1000)
        encoding = "rgb8" if raw.shape[2] == 3 else "mono8"
        self.info_pub.publish(camera_info_msg(stamp, k))
        self.image_pub.publish(image_msg(stamp, "cam_optical", raw, encoding))
        return stamp

    def exchange(self, raw):
        """Sends `raw` until both subscribers received its image_rect; returns them."""
        stamps = []

        def received():
            for stamp in stamps:
                got = [next((m for m in inbox.messages if stamp_of(m) == stamp), None)
                       for inbox in (self.reliable, self.sensor)]
                if all(got):
                    return got
            return None
        return self.peer.send_until(
            lambda: stamps.append(self.send(raw)), received,
            lambda: f"image_rect of a frame on both subscribers (so far reliable "
                    f"{self.reliable.count}, best-effort {self.sensor.count})")


def exchange_compressed(r, raw):
    """Sends `raw` through the Rectify `r` until its image_rect and image_rect/compressed
    both arrived; returns them."""
    stamps = []

    def received():
        for stamp in stamps:
            rect = next((m for m in r.reliable.messages if stamp_of(m) == stamp), None)
            packed = next((m for m in r.compressed.messages if stamp_of(m) == stamp), None)
            if rect is not None and packed is not None:
                return rect, packed
        return None
    return r.peer.send_until(lambda: stamps.append(r.send(raw)), received,
                             "image_rect and image_rect/compressed of a frame")


def compressed_difference(rect, packed):
    """Mean and largest |OpenCV's imdecode of image_rect/compressed - image_rect| in grey
    levels."""
    channels = 3 if rect.encoding == "rgb8" else 1
    pixels_rect = np.frombuffer(bytes(rect.data), np.uint8).reshape(
        rect.height, rect.width, channels)
    decoded = cv2.imdecode(np.frombuffer(bytes(packed.data), np.uint8), cv2.IMREAD_UNCHANGED)
    require(decoded is not None, f"OpenCV cannot decode image_rect/compressed ({packed.format!r})")
    decoded = decoded.reshape(rect.height, rect.width, channels)
    if channels == 3:
        decoded = decoded[..., ::-1]
    difference = np.abs(decoded.astype(int) - pixels_rect.astype(int))
    return float(difference.mean()), int(difference.max())


def opencv_jpeg_difference(rect, quality):
    """Mean |imdecode(imencode(image_rect, JPEG quality)) - image_rect| with OpenCV: the
    loss the JPEG of image_rect/compressed is held to."""
    channels = 3 if rect.encoding == "rgb8" else 1
    pixels_rect = np.frombuffer(bytes(rect.data), np.uint8).reshape(
        rect.height, rect.width, channels)
    bgr = pixels_rect if channels == 1 else np.ascontiguousarray(pixels_rect[..., ::-1])
    ok, jpeg = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, quality])
    require(ok, "cv2.imencode failed")
    decoded = cv2.imdecode(jpeg, cv2.IMREAD_UNCHANGED).reshape(bgr.shape)
    return float(np.abs(decoded.astype(int) - bgr.astype(int)).mean())


class RectifyCompressed:
    """rectify_node in /camz with `image_transport: compressed`, reading
    /camz/image_raw/compressed, and rclpy around it."""
    label, name, namespace = "rectify_node (compressed)", "rectify_node", "/camz"
    fqn = "/camz/rectify_node"

    def __init__(self, peer, binary):
        self.peer = peer
        node = peer.node
        self.image_pub = node.create_publisher(CompressedImage, "/camz/image_raw/compressed",
                                               RELIABLE)
        self.info_pub = node.create_publisher(CameraInfo, "/camz/camera_info", RELIABLE)
        self.rect = peer.subscribe(Image, "/camz/image_rect", RELIABLE)
        self.process = NodeProcess(
            [binary, "--ros-args", "-r", "__ns:=/camz", "-r", "image:=image_raw",
             "-p", "image_transport:=compressed"], peer.domain)
        peer.watch(self.process)
        self.sent = 0

    def send(self, data, format):
        """Publishes a compressed frame and its camera_info with a new stamp."""
        self.sent += 1
        stamp = (300, self.sent * 1000)
        self.info_pub.publish(camera_info_msg(stamp))
        self.image_pub.publish(CompressedImage(header=header(stamp, "cam_optical"), format=format,
                                               data=array.array("B", data)))
        return stamp

    def exchange(self, data, format):
        """Sends a compressed frame until its image_rect arrives; returns it."""
        stamps = []

        def received():
            return next((m for m in self.rect.messages if stamp_of(m) in stamps), None)
        return self.peer.send_until(lambda: stamps.append(self.send(data, format)), received,
                                    f"image_rect of a {format!r} frame")


def check_rectify_compressed(checks, peer, rosout, binary):
    r = RectifyCompressed(peer, binary)
    label = r.label
    try:
        if not discovered(checks, peer, label, r.name, r.namespace):
            return checks.skip(label, "the other checks", "the node was not discovered")

        with checks.check(label, "graph: image_raw/compressed subscribed"):
            graph_check(peer, r.name, r.namespace, {
                "publishers": {"/camz/image_rect": ["sensor_msgs/msg/Image"],
                               "/camz/image_rect/compressed":
                                   ["sensor_msgs/msg/CompressedImage"],
                               "/rosout": ["rcl_interfaces/msg/Log"],
                               "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
                "subscribers": {"/camz/image_raw/compressed": ["sensor_msgs/msg/CompressedImage"],
                                "/camz/camera_info": ["sensor_msgs/msg/CameraInfo"]},
                "services": parameter_services(r.fqn),
                "clients": {},
            })

        with checks.check(label, "PNG (mono8, rgb8): image_rect equal to OpenCV's remap of the "
                                 "image") as note:
            peer.wait_until(lambda: r.image_pub.get_subscription_count() > 0
                            and r.info_pub.get_subscription_count() > 0,
                            "rectify_node's image/compressed and camera_info subscriptions")
            worst = 0
            for index, (channels, format) in enumerate(((1, "mono8; png compressed"),
                                                        (3, "rgb8; png compressed rgb8"))):
                raw = pixels(index + 20, channels)
                # OpenCV writes what it takes as BGR: give it the channels reversed.
                ok, png = cv2.imencode(".png", raw if channels == 1 else raw[..., ::-1])
                require(ok, "cv2.imencode failed")
                msg = r.exchange(png.tobytes(), format)
                worst = max(worst, rect_difference(msg, raw, cv2.INTER_LINEAR))
            require(worst <= 1, f"image_rect differs from OpenCV (bilinear) by {worst}")
            note(f"|image_rect - OpenCV bilinear| <= {worst}")

        with checks.check(label, "JPEG (mono8): image_rect within 2 grey levels of OpenCV's "
                                 "imdecode + remap") as note:
            raw = pixels(30, 1)
            ok, jpeg = cv2.imencode(".jpg", raw, [cv2.IMWRITE_JPEG_QUALITY, 90])
            require(ok, "cv2.imencode failed")
            decoded = cv2.imdecode(jpeg, cv2.IMREAD_UNCHANGED).reshape(HEIGHT, WIDTH, 1)
            msg = r.exchange(jpeg.tobytes(), "mono8; jpeg compressed mono8")
            difference = rect_difference(msg, decoded, cv2.INTER_LINEAR)
            require(difference <= 2, f"image_rect differs from OpenCV's by {difference}")
            note(f"|image_rect - OpenCV imdecode + remap| <= {difference}")

        with checks.check(label, "bad input: a truncated JPEG is logged, the node goes on"):
            r.send(jpeg.tobytes()[:200], "mono8; jpeg compressed mono8")
            warning = peer.wait_until(
                lambda: next((m for m in rosout.messages if m.name == "camz.rectify_node"
                              and "image_raw/compressed" in m.msg
                              and "jpeg data could not be decoded" in m.msg), None),
                "a /rosout warning naming the topic and the undecodable JPEG", timeout=20)
            require(warning.level == Log.WARN, f"level {warning.level}: {warning.msg}")
            r.exchange(png.tobytes(), "rgb8; png compressed rgb8")
    finally:
        stop_and_check(checks, peer, r.process, label, r.name, r.namespace)


def rect_difference(msg, raw, interpolation):
    """Largest |image_rect - OpenCV| in grey levels, after checking the message's layout."""
    channels = raw.shape[2]
    want = ("rgb8" if channels == 3 else "mono8", WIDTH, HEIGHT, WIDTH * channels, "cam_optical")
    got = (msg.encoding, msg.width, msg.height, msg.step, msg.header.frame_id)
    require(got == want, f"image_rect {got}, expected {want}")
    image = np.frombuffer(msg.data, dtype=np.uint8).reshape(HEIGHT, WIDTH, channels)
    return int(np.abs(image.astype(int) - opencv_rectified(raw, interpolation).astype(int)).max())


def discovered(checks, peer, label, name, namespace):
    """The check "discovery": node `namespace`/`name` appears in the ROS graph. Whether
    it did."""
    with checks.check(label, "discovery: name and namespace in the graph"):
        peer.wait_until(lambda: (name, namespace) in peer.node_names(),
                        f"{namespace.rstrip('/')}/{name} in get_node_names_and_namespaces()")
    return checks.passed(label, "discovery: name and namespace in the graph")


def check_rectify(checks, peer, rosout, binary):
    r = Rectify(peer, binary)
    label = r.label
    try:
        if not discovered(checks, peer, label, r.name, r.namespace):
            return checks.skip(label, "the other checks", "the node was not discovered")

        with checks.check(label, "graph: topics, services and their types"):
            graph_check(peer, r.name, r.namespace, {
                "publishers": {"/cam/image_rect": ["sensor_msgs/msg/Image"],
                               "/cam/image_rect/compressed":
                                   ["sensor_msgs/msg/CompressedImage"],
                               "/rosout": ["rcl_interfaces/msg/Log"],
                               "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
                "subscribers": {"/cam/image_raw": ["sensor_msgs/msg/Image"],
                                "/cam/camera_info": ["sensor_msgs/msg/CameraInfo"]},
                "services": parameter_services(r.fqn),
                "clients": {},
            })

        with checks.check(label, "/rosout: warning on an uncalibrated camera_info"):
            peer.wait_until(lambda: r.image_pub.get_subscription_count() > 0
                            and r.info_pub.get_subscription_count() > 0,
                            "rectify_node's image and camera_info subscriptions")
            warning = peer.send_until(
                lambda: r.send(pixels(0, 1), k=[0.0] * 9),
                lambda: next((m for m in rosout.messages if m.name == "cam.rectify_node"
                              and "uncalibrated" in m.msg), None),
                "a /rosout record of logger cam.rectify_node about the uncalibrated camera_info")
            require(warning.level == Log.WARN, f"level {warning.level}, not WARN: {warning.msg}")

        with checks.check(label, "QoS: reliable and best-effort subscribers get image_rect") \
                as note:
            worst = 0
            for index in range(4):
                raw = pixels(index + 1, 3 if index % 2 else 1)
                for msg in r.exchange(raw):
                    worst = max(worst, rect_difference(msg, raw, cv2.INTER_LINEAR))
            require(worst <= 1, f"image_rect differs from OpenCV (bilinear) by {worst}")
            note(f"4 frames (mono8, rgb8) on each; |image_rect - OpenCV bilinear| <= {worst}")

        with checks.check(label, "image_rect/compressed while subscribed: JPEG (quality 95) "
                                 "by default, PNG once image_rect.compressed.format is png; "
                                 "OpenCV's imdecode against image_rect") as note:
            found = {}
            for codec in ("jpeg", "png"):
                if codec == "png":
                    [result] = r.params.set({"image_rect.compressed.format": "png"})
                    require(result.successful, f"set format=png refused: {result.reason!r}")
                for channels, encoding in ((1, "mono8"), (3, "rgb8")):
                    rect, packed = exchange_compressed(r, pixels(40 + channels, channels))
                    stored = "mono8" if channels == 1 else "bgr8"
                    want = f"{encoding}; {codec} compressed {stored}"
                    require(packed.format == want, f"format {packed.format!r}, not {want!r}")
                    require(packed.header.frame_id == rect.header.frame_id, "header differs")
                    found[(codec, encoding)] = compressed_difference(rect, packed)
                    if codec == "jpeg":
                        found[("opencv", encoding)] = opencv_jpeg_difference(rect, 95)
            png = [found[("png", e)] for e in ("mono8", "rgb8")]
            jpeg = [found[("jpeg", e)] for e in ("mono8", "rgb8")]
            require(all(m == 0 for _, m in png), f"PNG differs from image_rect: {png}")
            opencv = [found[("opencv", e)] for e in ("mono8", "rgb8")]
            # As lossy as OpenCV's own JPEG of image_rect at the same quality, give or
            # take the encoders' differences.
            require(all(mean <= 1.1 * cv for (mean, _), cv in zip(jpeg, opencv)),
                    f"JPEG mean difference from image_rect {jpeg}, OpenCV's at quality 95 "
                    f"{opencv}")
            note("PNG equal to image_rect; JPEG mean difference " + ", ".join(
                f"{e} {mean:.2f} (OpenCV's imencode {cv:.2f})"
                for e, (mean, _), cv in zip(("mono8", "rgb8"), jpeg, opencv)))

        common_parameter_checks(
            checks, label, r.params, {"interpolation": 1, "queue_size": 5,
                                      "image_rect.compressed.format": "png",
                                      "image_rect.compressed.jpeg_quality": 95,
                                      "image_rect.compressed.png_level": 3},
            read_only=["queue_size"],
            constraints={"image_rect.compressed.format": ["jpeg", "png"]},
            refuse=["queue_size"])

        with checks.check(label, "parameters: set interpolation 0 takes effect (nearest)") \
                as note:
            [result] = r.params.set({"interpolation": 0})
            require(result.successful, f"set interpolation=0 refused: {result.reason!r}")
            require(r.params.get(["interpolation"]) == [0], "interpolation is not 0 after the set")
            raw = pixels(9, 1)
            for msg in r.exchange(raw):
                nearest = rect_difference(msg, raw, cv2.INTER_NEAREST)
                linear = rect_difference(msg, raw, cv2.INTER_LINEAR)
                require(nearest <= 1 and linear > 1, f"image_rect differs from OpenCV nearest "
                        f"by {nearest}, bilinear by {linear}")
            note(f"|image_rect - OpenCV nearest| <= {nearest}, bilinear {linear}")

        with checks.check(label, "/parameter_events: the set of interpolation"):
            def event():
                for e in r.events.messages:
                    changed = {p.name: python_value(p.value) for p in e.changed_parameters}
                    if e.node == r.fqn and changed.get("interpolation") == 0:
                        return e
                return None
            peer.wait_until(event, lambda: "a ParameterEvent of node /cam/rectify_node changing "
                            "interpolation to 0; received: " + repr(
                                [(e.node, [p.name for p in e.changed_parameters])
                                 for e in r.events.messages][-5:]), timeout=20)

        with checks.check(label, "parameters: interpolation 7 (out of range) refused"):
            [result] = r.params.set({"interpolation": 7})
            require(not result.successful and result.reason.strip(),
                    f"successful={result.successful}, reason {result.reason!r}")
            now = r.params.get(["interpolation"])
            require(now == [0], f"interpolation is {now} after a refused set, not [0]")

        with checks.check(label, "parameters: atomic set with a bad value changes nothing"):
            result = r.params.set_atomically([("interpolation", 2), ("interpolation", 9)])
            require(not result.successful and "out of range" in result.reason,
                    f"successful={result.successful}, reason {result.reason!r}")
            result = r.params.set_atomically({"interpolation": 2, "queue_size": 6})
            require(not result.successful and "read-only" in result.reason,
                    f"successful={result.successful}, reason {result.reason!r}")
            now = r.params.get(["interpolation", "queue_size"])
            require(now == [0, 5], f"interpolation, queue_size are {now}, not [0, 5]")

        describe_all_check(checks, label, r.params)
    finally:
        stop_and_check(checks, peer, r.process, label, r.name, r.namespace)


# ---------------------------------------------------------------------------------------
# calibrate_node

FRAMES, SEED = 40, 3
LEFT, RIGHT = "/stereo/left/image_raw", "/stereo/right/image_raw"


def read_pairs(bag):
    """The bag's (left, right) images in stamp order, as rclpy messages."""
    frames = {LEFT: [], RIGHT: []}
    for topic, m in bag_messages(bag, frames):
        frames[topic].append(Image(
            header=header(stamp_of(m), m.header.frame_id), height=m.height, width=m.width,
            encoding=m.encoding, is_bigendian=m.is_bigendian, step=m.step,
            data=array.array("B", m.data.tobytes())))
    return list(zip(frames[LEFT], frames[RIGHT]))


def rotation_error_degrees(r, r_true):
    angle, _ = cv2.Rodrigues(np.asarray(r).reshape(3, 3) @ np.asarray(r_true).reshape(3, 3).T)
    return float(np.degrees(np.linalg.norm(angle)))


class Calibrate:
    """calibrate_node (stereo) in /stereo on image_raw, and rclpy around it: publishers
    of the pair, subscribers of its status and annotated images, a set_camera_info
    server for the left camera."""
    label, name, namespace = "calibrate_node", "calibrate_node", "/stereo"
    fqn = "/stereo/calibrate_node"

    def __init__(self, peer, binary, tmp, truth):
        self.peer = peer
        node = peer.node
        self.left = node.create_publisher(Image, LEFT, RELIABLE)
        self.right = node.create_publisher(Image, RIGHT, RELIABLE)
        self.status = peer.subscribe(String, f"{self.fqn}/status", STATUS_QOS)
        left, right = f"{self.fqn}/left/annotated_image", f"{self.fqn}/right/annotated_image"
        self.annotated = {
            "left, reliable": peer.subscribe(Image, left, RELIABLE, keep=2),
            "left, best-effort": peer.subscribe(Image, left, qos_profile_sensor_data, keep=2),
            "right, reliable": peer.subscribe(Image, right, RELIABLE, keep=2),
        }
        self.camera_infos = []
        node.create_service(SetCameraInfo, "/stereo/left/set_camera_info", self.set_camera_info)
        board = truth["board"]
        self.files = {name: tmp / f"{name}.yaml" for name in ("left", "right")}
        self.documented = {
            "pattern": "chessboard",
            "size": f"{board['inner_corners_cols']}x{board['inner_corners_rows']}",
            "square": float(board["square_size_m"]), "marker_size": 0.0,
            "dictionary": "4x4_50", "model": "plumb_bob", "stereo": True,
            "camera_name": "camera", "left_camera_name": "left", "right_camera_name": "right",
            "slop": 0.0, "max_board_speed": 0.0, "max_blur": 5.0, "auto_calibrate": False,
            "state_dir": str(tmp / "state"), "camera_info_url": "",
            "left_camera_info_url": f"file://{self.files['left']}",
            "right_camera_info_url": f"file://{self.files['right']}", "queue_size": 5,
        }
        overrides = [a for name in ("stereo", "size", "square", "state_dir",
                                    "left_camera_info_url", "right_camera_info_url")
                     for a in ("-p", f"{name}:={self.documented[name]}")]
        self.process = NodeProcess(
            [binary, "--ros-args", "-r", "__ns:=/stereo", "-r", "left/image:=left/image_raw",
             "-r", "right/image:=right/image_raw", *overrides], peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)

    def set_camera_info(self, request, response):
        self.camera_infos.append(request.camera_info)
        response.success = True
        response.status_message = "stored"
        return response

    def last_status(self):
        return json.loads(self.status.last.data) if self.status.last else None

    def send_pair(self, pair):
        """Sends a pair until the node has judged one more frame."""
        judged = self.last_status()["frames"]["judged"]

        def send():
            self.left.publish(pair[0])
            self.right.publish(pair[1])
        self.peer.send_until(
            send, lambda: self.last_status()["frames"]["judged"] > judged,
            lambda: f"the pair at {stamp_of(pair[0])} judged; status {self.last_status()}")


def check_calibration(calibration, truth):
    """The calibration in ~/status against the session's ground truth; returns the
    errors found, in words."""
    errors, worst = [], 0.0
    for record in truth["cameras"]:
        k_true = np.reshape(record["camera_matrix_row_major"], (3, 3))
        k = np.reshape(calibration["cameras"][record["name"]]["k"], (3, 3))
        for what, got, want in (("fx", k[0, 0], k_true[0, 0]), ("fy", k[1, 1], k_true[1, 1]),
                                ("cx", k[0, 2], k_true[0, 2]), ("cy", k[1, 2], k_true[1, 2])):
            worst = max(worst, abs(got - want))
            if abs(got - want) >= 0.2:
                errors.append(f"{record['name']} {what} {got:.3f}, truth {want:.3f}")
    rt = truth["extrinsics"]["right_from_left"]
    ours = calibration["stereo"]["right_from_left"]
    angle = rotation_error_degrees(ours["rotation"], rt["rotation_row_major"])
    offset = np.linalg.norm(np.subtract(ours["translation"], rt["translation_m"])) * 1e3
    if angle >= 0.1 or offset >= 1.0:
        errors.append(f"right_from_left off the truth by {angle:.4f} deg, {offset:.3f} mm")
    require(not errors, "; ".join(errors))
    return (f"fx fy cx cy within {worst:.3f} px of the truth, right_from_left "
            f"{angle:.4f} deg and {offset:.3f} mm off")


def check_camera_file(path, camera, calibration, size):
    """A committed camera_info YAML, read with PyYAML, against the calibration."""
    require(path.exists(), f"{path} not written")
    data = yaml.safe_load(path.read_text())
    ours = calibration["cameras"][camera]
    require(data["camera_name"] == camera and (data["image_width"], data["image_height"]) == size,
            f"{path}: camera {data['camera_name']!r}, {data['image_width']}x{data['image_height']}")
    require(data["distortion_model"] == ours["distortion_model"],
            f"{path}: distortion_model {data['distortion_model']!r}")
    for key, rows, cols in (("camera_matrix", 3, 3), ("rectification_matrix", 3, 3),
                            ("projection_matrix", 3, 4)):
        m = data[key]
        require((m["rows"], m["cols"], len(m["data"])) == (rows, cols, rows * cols),
                f"{path}: {key} is {m['rows']}x{m['cols']} with {len(m['data'])} values")
    require(np.allclose(data["camera_matrix"]["data"], ours["k"], rtol=1e-9),
            f"{path}: K {data['camera_matrix']['data']}, calibration {ours['k']}")
    require(np.allclose(data["distortion_coefficients"]["data"], ours["d"], rtol=1e-9, atol=1e-15),
            f"{path}: D {data['distortion_coefficients']['data']}, calibration {ours['d']}")
    r = np.reshape(data["rectification_matrix"]["data"], (3, 3))
    require(np.allclose(r @ r.T, np.eye(3), atol=1e-9) and abs(np.linalg.det(r) - 1) < 1e-9,
            f"{path}: R is not a rotation: {r.tolist()}")
    return data


def check_calibrate(checks, peer, rosout, binary, stereocal):
    label = Calibrate.label
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with checks.check(label, f"setup: stereocal synth, {FRAMES} stereo frames"):
            run = subprocess.run([stereocal, "synth", "--scene", "calibration", "--frames",
                                  str(FRAMES), "--seed", str(SEED), "--out", tmp / "scene"],
                                 capture_output=True, text=True)
            require(run.returncode == 0, f"stereocal synth failed:\n{run.stderr}")
            truth = json.loads((tmp / "scene" / "ground_truth.json").read_text())
            pairs = read_pairs(tmp / "scene" / "bag")
            require(len(pairs) == FRAMES, f"the synthesized bag has {len(pairs)} pairs")
        if not checks.passed(label, f"setup: stereocal synth, {FRAMES} stereo frames"):
            return checks.skip(label, "the other checks", "no synthesized session")
        size = (pairs[0][0].width, pairs[0][0].height)
        c = Calibrate(peer, binary, tmp, truth)
        try:
            calibrate_checks(checks, peer, rosout, c, pairs, truth, size)
        finally:
            stop_and_check(checks, peer, c.process, label, c.name, c.namespace)


def calibrate_checks(checks, peer, rosout, c, pairs, truth, size):
    label, fqn = c.label, c.fqn
    if not discovered(checks, peer, label, c.name, c.namespace):
        return checks.skip(label, "the other checks", "the node was not discovered")

    with checks.check(label, "graph: topics, services, clients and their types"):
        trigger = ["std_srvs/srv/Trigger"]
        graph_check(peer, c.name, c.namespace, {
            "publishers": {f"{fqn}/status": ["std_msgs/msg/String"],
                           f"{fqn}/left/annotated_image": ["sensor_msgs/msg/Image"],
                           f"{fqn}/right/annotated_image": ["sensor_msgs/msg/Image"],
                           "/rosout": ["rcl_interfaces/msg/Log"],
                           "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
            "subscribers": {LEFT: ["sensor_msgs/msg/Image"], RIGHT: ["sensor_msgs/msg/Image"]},
            "services": {f"{fqn}/calibrate": trigger, f"{fqn}/commit": trigger,
                         f"{fqn}/reset": trigger, **parameter_services(fqn)},
            "clients": {"/stereo/left/set_camera_info": ["sensor_msgs/srv/SetCameraInfo"],
                        "/stereo/right/set_camera_info": ["sensor_msgs/srv/SetCameraInfo"]},
        })

    with checks.check(label, "~/status: progress JSON at start-up"):
        status = peer.wait_until(c.last_status, f"{fqn}/status")
        require([cam["name"] for cam in status["cameras"]] == ["left", "right"]
                and status["samples"] == 0 and status["calibration"] is None,
                f"start-up status {status}")
    if not checks.passed(label, "~/status: progress JSON at start-up"):
        return checks.skip(label, "the other checks", "no ~/status to follow the node by")

    with checks.check(label, "~/calibrate and ~/commit refused before enough samples"):
        early = peer.trigger(f"{fqn}/calibrate")
        require(not early.success and "not enough samples" in early.message,
                f"~/calibrate: success={early.success}, {early.message!r}")
        early = peer.trigger(f"{fqn}/commit")
        require(not early.success and "~/calibrate first" in early.message,
                f"~/commit: success={early.success}, {early.message!r}")

    with checks.check(label, f"session: {FRAMES} pairs from rclpy judged, coverage ready") as note:
        peer.wait_until(lambda: c.left.get_subscription_count() > 0
                        and c.right.get_subscription_count() > 0,
                        "calibrate_node's image subscriptions")
        for pair in pairs:
            c.send_pair(pair)
        status = c.last_status()
        require(status["frames"]["judged"] >= FRAMES and status["ready"]
                and 20 <= status["samples"] < FRAMES, f"after {FRAMES} pairs: {status}")
        note(f"{status['samples']} samples kept, frames {status['frames']}")

    with checks.check(label, "QoS: reliable and best-effort subscribers get annotated images") \
            as note:
        sent = {stamp_of(p[0]) for p in pairs}
        for what, inbox in c.annotated.items():
            peer.wait_until(lambda: inbox.count > 0, f"an annotated image ({what})")
            m = inbox.last
            require((m.encoding, m.width, m.height, m.step) == ("rgb8", *size, size[0] * 3)
                    and stamp_of(m) in sent,
                    f"annotated image ({what}): {m.encoding} {m.width}x{m.height} "
                    f"step {m.step} at {stamp_of(m)}")
        note("received " + ", ".join(f"{i.count} ({w})" for w, i in c.annotated.items()))

    with checks.check(label, "/rosout: 'sample added' records"):
        peer.wait_until(lambda: any(m.name == "stereo.calibrate_node" and "sample added" in m.msg
                                    for m in rosout.messages),
                        "a /rosout record of logger stereo.calibrate_node saying 'sample added'",
                        timeout=20)

    with checks.check(label, "~/calibrate: result against the ground truth") as note:
        answer = peer.trigger(f"{fqn}/calibrate")
        require(answer.success, f"~/calibrate refused: {answer.message!r}")
        for part in ("left: RMS", "right: RMS", "epipolar RMS"):
            require(part in answer.message, f"~/calibrate answered {answer.message!r}")
        status = peer.wait_until(lambda: c.last_status()["calibration"] and c.last_status(),
                                 "a ~/status with the calibration")
        note(check_calibration(status["calibration"], truth))

    with checks.check(label, "~/commit: camera_info YAML and set_camera_info"):
        statuses = c.status.count
        answer = peer.trigger(f"{fqn}/commit")
        require(answer.success, f"~/commit failed: {answer.message!r}")
        for part in ("acknowledged by /stereo/left/set_camera_info",
                     "no /stereo/right/set_camera_info server answered"):
            require(part in answer.message, f"~/commit answered {answer.message!r}")
        calibration = c.last_status()["calibration"]
        files = {cam: check_camera_file(path, cam, calibration, size)
                 for cam, path in c.files.items()}
        require(files["left"]["projection_matrix"]["data"][5:7]
                == files["right"]["projection_matrix"]["data"][5:7],
                "the pair's projection matrices do not share fy and cy")
        require(len(c.camera_infos) == 1, f"set_camera_info got {len(c.camera_infos)} requests")
        info, left = c.camera_infos[0], files["left"]
        for field, key in (("k", "camera_matrix"), ("r", "rectification_matrix"),
                           ("p", "projection_matrix"), ("d", "distortion_coefficients")):
            sent = list(getattr(info, field))
            require(np.allclose(sent, left[key]["data"], rtol=1e-9, atol=1e-15),
                    f"set_camera_info {field} {sent}, file {left[key]['data']}")

    with checks.check(label, "~/status: transient local to a late subscriber"):
        # The node publishes its status after answering a call: once that one is here,
        # nothing new is sent, and a subscriber made now can only get it from history.
        peer.wait_until(lambda: c.status.count > statuses, "the status sent after ~/commit")
        statuses = c.status.count
        late = peer.subscribe(String, f"{fqn}/status", STATUS_QOS)
        peer.wait_until(lambda: late.last and late.last.data == c.status.last.data,
                        lambda: "the last status on a subscriber created after it was sent; "
                                f"got {late.count} message(s)")
        require(c.status.count == statuses, "the node sent a new status meanwhile")

    with checks.check(label, "~/reset: every sample forgotten"):
        answer = peer.trigger(f"{fqn}/reset")
        require(answer.success, f"~/reset failed: {answer.message!r}")
        peer.wait_until(lambda: c.last_status()["samples"] == 0
                        and c.last_status()["calibration"] is None,
                        lambda: f"a status with no samples; last {c.last_status()}")
        again = peer.trigger(f"{fqn}/calibrate")
        require(not again.success, f"~/calibrate after ~/reset: {again.message!r}")

    # The node reads every parameter once, at start-up: all are read-only.
    common_parameter_checks(
        checks, label, c.params, c.documented, read_only=list(c.documented),
        constraints={"pattern": ["chessboard", "charuco", "circles", "acircles"],
                     "model": ["plumb_bob", "rational_polynomial", "equidistant"]},
        refuse=["queue_size", "pattern"])
    describe_all_check(checks, label, c.params)


# ---------------------------------------------------------------------------------------
# pose_node

TARGET_POSE, WITH_COVARIANCE = "/camera/target_pose", "/camera/target_pose_with_covariance"


def rclpy_frame(image, info):
    """A session frame (rosbags messages) as rclpy's Image and CameraInfo."""
    stamp = stamp_of(image)
    roi = info.roi
    return (
        Image(header=header(stamp, image.header.frame_id), height=image.height,
              width=image.width, encoding=image.encoding, is_bigendian=image.is_bigendian,
              step=image.step, data=array.array("B", image.data.tobytes())),
        CameraInfo(header=header(stamp_of(info), info.header.frame_id), height=info.height,
                   width=info.width, distortion_model=info.distortion_model,
                   d=[float(v) for v in info.d], k=[float(v) for v in info.k],
                   r=[float(v) for v in info.r], p=[float(v) for v in info.p],
                   binning_x=info.binning_x, binning_y=info.binning_y,
                   roi=RegionOfInterest(x_offset=roi.x_offset, y_offset=roi.y_offset,
                                        height=roi.height, width=roi.width,
                                        do_rectify=roi.do_rectify)),
    )


def restamped(frame, seconds, image=None, **info_fields):
    """Copies of a frame `seconds` later, with `image` for its pixels when given and
    camera_info fields replaced by `info_fields`."""
    msg, info = copy.deepcopy(frame)
    stamp = (msg.header.stamp.sec + seconds, msg.header.stamp.nanosec)
    msg.header = info.header = header(stamp, msg.header.frame_id)
    if image is not None:
        msg.data = array.array("B", image.tobytes())
    for field, value in info_fields.items():
        setattr(info, field, value)
    return msg, info


class Pose:
    """pose_node in /camera on image_raw, and rclpy around it: publishers of the frames,
    a default reliable and a best-effort subscriber of target_pose, subscribers of
    target_pose_with_covariance and of the status."""
    label, name, namespace = "pose_node", "pose_node", "/camera"
    fqn = "/camera/pose_node"

    def __init__(self, peer, binary, session):
        self.peer = peer
        node = peer.node
        self.image_pub = node.create_publisher(Image, IMAGE_RAW, RELIABLE)
        self.info_pub = node.create_publisher(CameraInfo, CAMERA_INFO, RELIABLE)
        self.reliable = peer.subscribe(PoseStamped, TARGET_POSE, RELIABLE)
        self.sensor = peer.subscribe(PoseStamped, TARGET_POSE, qos_profile_sensor_data)
        self.with_covariance = peer.subscribe(PoseWithCovarianceStamped, WITH_COVARIANCE,
                                              RELIABLE)
        self.status = peer.subscribe(String, f"{self.fqn}/status", STATUS_QOS)
        size, square = session.size_parameters()
        self.documented = {
            "pattern": "chessboard", "size": size, "square": square, "marker_size": 0.0,
            "dictionary": "4x4_50", "target_frame": "target", "camera_frame": "",
            "max_reprojection_error": 2.0, "min_ambiguity_significance": 3.0,
            "pixel_noise": 0.1, "image_is_rectified": False, "publish_tf": True,
            "queue_size": 5,
        }
        self.command = [binary, "--ros-args", "-r", "__ns:=/camera", "-r", "image:=image_raw",
                        "-p", f"size:={size}", "-p", f"square:={square}"]
        self.process = NodeProcess(self.command, peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)

    def last_status(self):
        return json.loads(self.status.last.data) if self.status.last else None

    def rejections(self, kind):
        return self.last_status()["rejections"].get(kind, 0)

    def received(self, stamp):
        """The frame's target_pose on the reliable and the best-effort subscriber and its
        target_pose_with_covariance, once all three are here; else None."""
        got = [next((m for m in inbox.messages if stamp_of(m) == stamp), None)
               for inbox in (self.reliable, self.sensor, self.with_covariance)]
        return got if all(got) else None

    def send_until(self, frame, condition, what):
        """Publishes the frame's camera_info and image, again while `condition()` does
        not hold (the node reads them best-effort); returns the condition's value."""
        def send():
            self.info_pub.publish(frame[1])
            self.image_pub.publish(frame[0])
        return self.peer.send_until(
            send, condition, lambda: f"{what} (frame {stamp_of(frame[0])}); status "
                                     f"{self.last_status()}")


def pose_of(pose):
    """A geometry_msgs/Pose as (rotation matrix, translation)."""
    return rotation_of(pose.orientation), [pose.position.x, pose.position.y, pose.position.z]


def covariance_problems(covariance, record):
    """What is wrong with a PoseWithCovariance's covariance: not 36 entries, not
    symmetric positive semi-definite, or not `stereocal pose --json`'s (`record`)."""
    if len(covariance) != 36:
        return [f"{len(covariance)} entries"]
    c = np.reshape(covariance, (6, 6))
    scale = float(np.abs(c).max())
    problems = []
    if scale == 0.0 or not np.all(np.isfinite(c)):
        problems.append(f"covariance {c.tolist()}")
    elif not np.allclose(c, c.T, rtol=0, atol=1e-9 * scale):
        problems.append("not symmetric")
    elif np.linalg.eigvalsh(c).min() < -1e-9 * scale:
        problems.append(f"an eigenvalue {np.linalg.eigvalsh(c).min():.3g} < 0")
    if not np.allclose(c.ravel(), record["covariance"], rtol=1e-9, atol=1e-12 * scale):
        problems.append("not stereocal pose --json's covariance")
    return problems


def check_pose(checks, peer, rosout, binary, stereocal):
    label = Pose.label
    setup = f"setup: stereocal synth (eye-in-hand, {POSE_FRAMES} frames), stereocal pose --json"
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup) as note:
            session = synthesize(stereocal, tmp)
            frames = [rclpy_frame(*f) for f in session.frames()]
            require(len(frames) == POSE_FRAMES and len(session.offline) == POSE_FRAMES,
                    f"{len(frames)} frames in the bag, {len(session.offline)} --json records")
            rejected = [r for r in session.offline.values() if "rejected" in r]
            require(not rejected, f"stereocal pose rejected frames: {rejected}")
            note(f"{frames[0][0].width}x{frames[0][0].height} {frames[0][0].encoding}")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no synthesized session")
        p = Pose(peer, binary, session)
        try:
            pose_checks(checks, peer, rosout, p, session, frames)
        finally:
            stop_and_check(checks, peer, p.process, label, p.name, p.namespace)


def pose_checks(checks, peer, rosout, p, session, frames):
    label, fqn = p.label, p.fqn
    if not discovered(checks, peer, label, p.name, p.namespace):
        return checks.skip(label, "the other checks", "the node was not discovered")

    # rclpy has no tf2_msgs (no wheel): /tf's type is checked by the name discovery gives;
    # its messages are received by Cyclone DDS (interop/check_pose_cyclone.py).
    with checks.check(label, "graph: topics, services and their types (/tf's by name)"):
        graph_check(peer, p.name, p.namespace, {
            "publishers": {TARGET_POSE: ["geometry_msgs/msg/PoseStamped"],
                           WITH_COVARIANCE: ["geometry_msgs/msg/PoseWithCovarianceStamped"],
                           "/tf": ["tf2_msgs/msg/TFMessage"],
                           f"{fqn}/annotated_image": ["sensor_msgs/msg/Image"],
                           f"{fqn}/status": ["std_msgs/msg/String"],
                           "/rosout": ["rcl_interfaces/msg/Log"],
                           "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
            "subscribers": {IMAGE_RAW: ["sensor_msgs/msg/Image"],
                            CAMERA_INFO: ["sensor_msgs/msg/CameraInfo"]},
            "services": parameter_services(fqn),
            "clients": {},
        })

    with checks.check(label, "~/status: JSON at start-up"):
        status = peer.wait_until(p.last_status, f"{fqn}/status")
        require(status["frames"]["received"] == 0 and status["frames"]["poses"] == 0
                and status["rejections"] == {} and status["last"] is None,
                f"start-up status {status}")
    if not checks.passed(label, "~/status: JSON at start-up"):
        return checks.skip(label, "the other checks", "no ~/status to follow the node by")

    session_check = (f"QoS: reliable and best-effort subscribers get target_pose of "
                     f"{POSE_FRAMES} frames")
    answers = {}
    with checks.check(label, session_check) as note:
        peer.wait_until(lambda: p.image_pub.get_subscription_count() > 0
                        and p.info_pub.get_subscription_count() > 0,
                        "pose_node's image and camera_info subscriptions")
        for frame in frames:
            stamp = stamp_of(frame[0])
            answers[stamp] = p.send_until(
                frame, lambda: p.received(stamp),
                "target_pose on both subscribers and target_pose_with_covariance")
        note(f"received {p.reliable.count} (reliable), {p.sensor.count} (best-effort), "
             f"{p.with_covariance.count} with covariance")
    if not checks.passed(label, session_check):
        return checks.skip(label, "the other checks", "no poses to check")

    with checks.check(label, "target_pose: image stamp and frame_id, against the ground "
                             f"truth ({TRUTH_DEGREES} deg, {TRUTH_MM} mm)") as note:
        frame_ids = {stamp_of(image): image.header.frame_id for image, _ in frames}
        worst_degrees = worst_mm = 0.0
        for stamp, (reliable, sensor, _) in answers.items():
            for msg in (reliable, sensor):
                require(msg.header.frame_id == frame_ids[stamp],
                        f"frame {stamp}: frame_id {msg.header.frame_id!r}, the image's "
                        f"{frame_ids[stamp]!r}")
                require(abs(quaternion_norm(msg.pose.orientation) - 1) < 1e-9,
                        f"frame {stamp}: |q| = {quaternion_norm(msg.pose.orientation)}")
            require(reliable.pose == sensor.pose, f"frame {stamp}: the subscribers got "
                    f"different poses: {reliable.pose} and {sensor.pose}")
            degrees, mm = truth_error(*pose_of(reliable.pose), session.truth[stamp])
            require(degrees < TRUTH_DEGREES and mm < TRUTH_MM,
                    f"frame {stamp}: {degrees:.4f} deg, {mm:.3f} mm from the truth")
            worst_degrees, worst_mm = max(worst_degrees, degrees), max(worst_mm, mm)
        note(f"worst {worst_degrees:.4f} deg, {worst_mm:.3f} mm")

    with checks.check(label, f"target_pose: equal to stereocal pose --json "
                             f"({OFFLINE_TOLERANCE:g})") as note:
        worst = max(offline_difference(*pose_of(reliable.pose), session.offline[stamp])
                    for stamp, (reliable, _, _) in answers.items())
        require(worst <= OFFLINE_TOLERANCE, f"a pose differs from the offline one by {worst:.3g}")
        note(f"largest difference {worst:.3g}")

    with checks.check(label, "target_pose_with_covariance: the pose, a 36-entry PSD "
                             "covariance (as --json's)"):
        for stamp, (reliable, _, with_covariance) in answers.items():
            require(with_covariance.header == reliable.header
                    and with_covariance.pose.pose == reliable.pose,
                    f"frame {stamp}: {with_covariance.header} {with_covariance.pose.pose}, "
                    f"target_pose {reliable.header} {reliable.pose}")
            problems = covariance_problems(list(with_covariance.pose.covariance),
                                           session.offline[stamp])
            require(not problems, f"frame {stamp}: " + "; ".join(problems))

    with checks.check(label, "~/status: frame counts, transient local to a late subscriber") \
            as note:
        # The node publishes its status when its counts change, at most once a second:
        # once a status counts every frame it received as handled, nothing new is sent,
        # and a subscriber made now can only get that one from history.
        def settled():
            status = p.last_status()
            counts = status["frames"]
            return (counts["poses"] >= len(answers) and counts["received"]
                    == counts["poses"] + counts["rejected"] + counts["dropped"]) and status
        status = peer.wait_until(settled, lambda: f"a status counting the session's "
                                 f"{len(answers)} poses; last {p.last_status()}")
        statuses = p.status.count
        late = peer.subscribe(String, f"{fqn}/status", STATUS_QOS)
        peer.wait_until(lambda: late.last and late.last.data == p.status.last.data,
                        lambda: "the last status on a subscriber created after it was sent; "
                                f"got {late.count} message(s)")
        require(p.status.count == statuses, "the node sent a new status meanwhile")
        require(status["frames"]["poses"] == p.reliable.count,
                f"status counts {status['frames']['poses']} poses, target_pose brought "
                f"{p.reliable.count}")
        note(f"frames {status['frames']}")

    with checks.check(label, "bad input: K[0] = 0 and no target publish no pose, counted "
                             "in rejections") as note:
        blank = np.full((frames[0][0].height, frames[0][0].step), 200, np.uint8)
        k = list(frames[0][1].k)
        uncalibrated = restamped(frames[0], 100, k=[0.0] + k[1:])
        no_target = restamped(frames[0], 101, image=blank)
        before = dict(p.last_status()["rejections"])
        for frame, kind, what in ((uncalibrated, "camera_info", "an uncalibrated camera_info"),
                                  (no_target, "not_visible", "an image without the target")):
            p.send_until(frame, lambda: p.rejections(kind) > before.get(kind, 0),
                         f"rejections.{kind} counting {what}")
        # Frames are handled in order: once a later frame's pose is here, a pose of the
        # bad ones would be too.
        after = restamped(frames[0], 102)
        p.send_until(after, lambda: p.received(stamp_of(after[0])), "the pose of the next frame")
        bad = {stamp_of(uncalibrated[0]), stamp_of(no_target[0])}
        published = [stamp_of(m) for inbox in (p.reliable, p.sensor, p.with_covariance)
                     for m in inbox.messages if stamp_of(m) in bad]
        require(not published, f"poses published for bad frames at {published}")
        status = p.last_status()
        require(status["last_rejection"], f"no last_rejection in {status}")
        note(f"rejections {status['rejections']}")

    with checks.check(label, "/rosout: 'no pose' warning with the logger's name"):
        warning = peer.wait_until(
            lambda: next((m for m in rosout.messages if m.name == "camera.pose_node"
                          and "no pose" in m.msg and "uncalibrated" in m.msg), None),
            "a /rosout record of logger camera.pose_node saying 'no pose' for the "
            "uncalibrated camera_info", timeout=20)
        require(warning.level == Log.WARN, f"level {warning.level}, not WARN: {warning.msg}")

    # The node reads every parameter once, at start-up: all are read-only.
    common_parameter_checks(
        checks, label, p.params, p.documented, read_only=list(p.documented),
        constraints={"pattern": ["chessboard", "charuco", "circles", "acircles"]},
        refuse=["queue_size", "pattern", "target_frame"])

    with checks.check(label, "parameters: max_reprojection_error -1 (out of range) refused, "
                             "at start-up too") as note:
        [descriptor] = p.params.describe(["max_reprojection_error"])
        [described] = descriptor.floating_point_range
        require(not described.from_value <= -1.0 <= described.to_value,
                f"-1 is within the described range {described}")
        # While the node runs the parameter is read-only, which is the reason given.
        [result] = p.params.set({"max_reprojection_error": -1.0})
        require(not result.successful and result.reason.strip(),
                f"successful={result.successful}, reason {result.reason!r}")
        now = p.params.get(["max_reprojection_error"])
        require(now == [2.0], f"max_reprojection_error is {now} after a refused set, not [2.0]")
        # The range itself is enforced on the values a node starts with.
        refused = NodeProcess([*p.command, "-p", "max_reprojection_error:=-1.0"], peer.domain)
        try:
            code = refused.process.wait(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            code = None
        refused.stop()
        require(code not in (None, 0) and "max_reprojection_error" in refused.logs()
                and "out of range" in refused.logs(),
                lambda: "pose_node started with max_reprojection_error:=-1.0: "
                        + ("still running" if code is None else f"exit code {code}")
                        + f"\n{refused.logs()[-2000:]}")
        note(f"described range {described.from_value:g}..{described.to_value:g}; refused "
             f"while running ({result.reason.split(':')[0]}), at start-up with exit code "
             f"{code}: {refused.logs().strip().splitlines()[-1]!r}")

    describe_all_check(checks, label, p.params)


# ---------------------------------------------------------------------------------------
# handeye_node

ROBOT_POSE = "/robot/tool_pose"
#: Frames of the hand-eye session: the robot stands still around each.
HANDEYE_FRAMES = 6


def rclpy_pose(msg):
    """A rosbags PoseStamped as rclpy's."""
    p, q = msg.pose.position, msg.pose.orientation
    out = PoseStamped(header=header(stamp_of(msg), msg.header.frame_id))
    out.pose.position.x, out.pose.position.y, out.pose.position.z = p.x, p.y, p.z
    (out.pose.orientation.x, out.pose.orientation.y, out.pose.orientation.z,
     out.pose.orientation.w) = q.x, q.y, q.z, q.w
    return out


def seconds_of(stamp):
    return stamp[0] + stamp[1] * 1e-9


class HandEye:
    """handeye_node at the root, on the camera's images and the robot's PoseStamped
    topic, and rclpy around it: publishers of both, a subscriber of the status."""
    label, name, namespace = "handeye_node", "handeye_node", "/"
    fqn = "/handeye_node"

    def __init__(self, peer, binary, size, square, state_dir):
        self.peer = peer
        node = peer.node
        self.image_pub = node.create_publisher(Image, IMAGE_RAW, RELIABLE)
        self.info_pub = node.create_publisher(CameraInfo, CAMERA_INFO, RELIABLE)
        self.robot_pub = node.create_publisher(PoseStamped, ROBOT_POSE, QoSProfile(depth=1000))
        self.status = peer.subscribe(String, f"{self.fqn}/status", STATUS_QOS)
        self.documented = {
            "setup": "eye_in_hand", "target_source": "image", "robot_source": "topic",
            "base_frame": "base", "tool_frame": "tool", "camera_frame": "",
            "max_time_difference": 0.02, "stillness_time": 0.5, "stillness_tolerance": 0.001,
            "auto_sample": False, "pattern": "chessboard", "size": size, "square": square,
            "state_dir": str(state_dir), "queue_size": 5,
        }
        self.process = NodeProcess(
            [binary, "--ros-args", "-r", f"image:={IMAGE_RAW}", "-r", f"camera_info:={CAMERA_INFO}",
             "-r", f"robot_pose:={ROBOT_POSE}", "-p", "robot_source:=topic", "-p", "base_frame:=base",
             "-p", "tool_frame:=tool", "-p", f"size:={size}", "-p", f"square:={square}",
             "-p", f"state_dir:={state_dir}"], peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)

    def last_status(self):
        return json.loads(self.status.last.data) if self.status.last else None

    def send_until_judged(self, frame):
        """Publishes the frame again while the status shows no verdict on it."""
        stamp = seconds_of(stamp_of(frame[0]))

        def judged():
            status = self.last_status()
            latest = status and status["latest"]
            return latest if latest and latest["stamp"] == stamp else None

        def send():
            self.info_pub.publish(frame[1])
            self.image_pub.publish(frame[0])
        return self.peer.send_until(send, judged, lambda: f"a verdict on the frame at {stamp} s; "
                                                          f"status {self.last_status()}")


def check_handeye(checks, peer, rosout, binary, stereocal):
    label = HandEye.label
    setup = f"setup: stereocal synth (eye-in-hand, {HANDEYE_FRAMES} frames), stereocal handeye"
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup) as note:
            session = synthesize(stereocal, tmp, frames=HANDEYE_FRAMES)
            frames = [rclpy_frame(*f) for f in session.frames()]
            robot = [rclpy_pose(m) for _, m in bag_messages(session.bag, (ROBOT_POSE,))]
            size, square = session.size_parameters()
            run = subprocess.run(
                [str(stereocal), "handeye", "--bag", str(session.bag), "--setup", "eye-in-hand",
                 "--image-topic", IMAGE_RAW, "--size", size, "--square", str(square),
                 "--robot-pose-topic", ROBOT_POSE, "--out", str(Path(tmp) / "offline"), "--json"],
                capture_output=True, text=True)
            require(run.returncode == 0, f"stereocal handeye failed:\n{run.stderr}")
            offline = json.loads(run.stdout)
            truth = json.loads((Path(tmp) / "scene" / "ground_truth.json").read_text())
            require(len(frames) == HANDEYE_FRAMES and robot, f"{len(frames)} frames, "
                    f"{len(robot)} robot poses")
            note(f"{len(robot)} robot poses; offline {offline['chosen']}")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no synthesized session")
        h = HandEye(peer, binary, size, square, Path(tmp) / "state")
        try:
            handeye_checks(checks, peer, rosout, h, frames, robot, offline, truth, Path(tmp))
        finally:
            stop_and_check(checks, peer, h.process, label, h.name, h.namespace)


def handeye_checks(checks, peer, rosout, h, frames, robot, offline, truth, tmp):
    label, fqn = h.label, h.fqn
    if not discovered(checks, peer, label, h.name, h.namespace):
        return checks.skip(label, "the other checks", "the node was not discovered")

    with checks.check(label, "graph: topics, services and their types (/tf_static's by name)"):
        trigger = ["std_srvs/srv/Trigger"]
        graph_check(peer, h.name, h.namespace, {
            "publishers": {f"{fqn}/status": ["std_msgs/msg/String"],
                           "/tf_static": ["tf2_msgs/msg/TFMessage"],
                           "/rosout": ["rcl_interfaces/msg/Log"],
                           "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
            "subscribers": {IMAGE_RAW: ["sensor_msgs/msg/Image"],
                            CAMERA_INFO: ["sensor_msgs/msg/CameraInfo"],
                            ROBOT_POSE: ["geometry_msgs/msg/PoseStamped"]},
            "services": {**{f"{fqn}/{s}": trigger for s in ("take_sample", "compute", "save",
                                                            "reset")},
                         f"{fqn}/remove_sample": ["stereocal_msgs/srv/RemoveSample"],
                         **parameter_services(fqn)},
            "clients": {},
        })

    with checks.check(label, "~/status: JSON at start-up"):
        status = peer.wait_until(h.last_status, f"{fqn}/status")
        require(status["samples"] == [] and status["result"] is None
                and status["setup"] == "eye-in-hand", f"start-up status {status}")
    if not checks.passed(label, "~/status: JSON at start-up"):
        return checks.skip(label, "the other checks", "no ~/status to follow the node by")

    with checks.check(label, "~/take_sample and ~/compute refused with the reason before "
                             "any frame") as note:
        early = peer.trigger(f"{fqn}/take_sample")
        require(not early.success and "no target frame yet" in early.message, f"{early}")
        compute = peer.trigger(f"{fqn}/compute")
        require(not compute.success and "too few samples" in compute.message, f"{compute}")
        note(f"{early.message!r}; {compute.message!r}")

    session_check = f"~/take_sample: {len(frames)} samples with the robot still"
    with checks.check(label, session_check) as note:
        peer.wait_until(lambda: h.image_pub.get_subscription_count() > 0
                        and h.robot_pub.get_subscription_count() > 0,
                        "handeye_node's image and robot_pose subscriptions")
        sent = 0
        for k, frame in enumerate(frames):
            stamp = seconds_of(stamp_of(frame[0]))
            while sent < len(robot) and seconds_of(stamp_of(robot[sent])) <= stamp + 0.1:
                h.robot_pub.publish(robot[sent])
                sent += 1
            latest = h.send_until_judged(frame)
            require(latest["ready"], f"frame {k}: {latest}")
            taken = peer.trigger(f"{fqn}/take_sample")
            require(taken.success, f"frame {k}: {taken.message}")
            peer.wait_until(lambda: len(h.last_status()["samples"]) == k + 1,
                            lambda: f"sample {k} in the status: {h.last_status()}")
        note(f"{len(frames)} samples, {sent} robot poses sent")
    if not checks.passed(label, session_check):
        return checks.skip(label, "the other checks", "no samples")

    with checks.check(label, "~/compute: equal to stereocal handeye, near the truth") as note:
        computed = peer.trigger(f"{fqn}/compute")
        require(computed.success and "/tf_static" in computed.message, computed.message)
        result = peer.wait_until(lambda: h.last_status()["result"], "the result in the status")
        require(result["chosen"] == offline["chosen"] == "refined",
                f"chose {result['chosen']}, offline {offline['chosen']}")
        node_t, offline_t = result["transform"], offline["results"]["refined"]
        difference = max(float(np.abs(np.subtract(node_t["rotation"], offline_t["rotation"])).max()),
                         float(np.abs(np.subtract(node_t["translation"],
                                                  offline_t["translation"])).max()))
        require(difference < 1e-9, f"differs from stereocal handeye by {difference:.3g}")
        tool_from_camera = truth["extrinsics"]["tool_from_camera"]
        r_true = np.reshape(tool_from_camera["rotation_row_major"], (3, 3))
        angle, _ = cv2.Rodrigues(np.reshape(node_t["rotation"], (3, 3)) @ r_true.T)
        degrees = float(np.degrees(np.linalg.norm(angle)))
        mm = float(np.linalg.norm(np.subtract(node_t["translation"],
                                              tool_from_camera["translation_m"])) * 1e3)
        u = result["uncertainty"]
        require(degrees < 3 * u["rotation_deg"] and mm < 3 * u["translation_mm"],
                f"{degrees:.4f} deg, {mm:.3f} mm from the truth; predicted {u}")
        note(f"{degrees:.4f} deg, {mm:.3f} mm from the truth (predicted {u['rotation_deg']:.4f} "
             f"deg, {u['translation_mm']:.3f} mm); {difference:.1g} from offline")

    with checks.check(label, "~/save: the YAML and report.html"):
        saved = peer.trigger(f"{fqn}/save")
        require(saved.success, saved.message)
        written = yaml.safe_load((tmp / "state" / "handeye.yaml").read_text())
        require(written["chosen"] == "refined" and written["samples"] == len(frames),
                f"handeye.yaml: chosen {written['chosen']}, {written['samples']} samples")
        require((tmp / "state" / "report.html").exists(), "no report.html")

    with checks.check(label, "~/status: transient local to a late subscriber"):
        late = peer.subscribe(String, f"{fqn}/status", STATUS_QOS)
        peer.wait_until(lambda: late.last and json.loads(late.last.data)["result"],
                        "the status with the result on a subscriber created after it")

    with checks.check(label, "/rosout: the samples taken, with the logger's name"):
        peer.wait_until(
            lambda: next((m for m in rosout.messages if m.name == "handeye_node"
                          and "take_sample" in m.msg and "taken" in m.msg), None),
            "a /rosout record of logger handeye_node saying a sample was taken", timeout=20)

    with checks.check(label, "~/reset: every sample moved aside"):
        reset = peer.trigger(f"{fqn}/reset")
        require(reset.success, reset.message)
        peer.wait_until(lambda: h.last_status()["samples"] == [], "no samples in the status")
        require((tmp / "state" / "reset-1").is_dir(), "no reset-1 folder in state_dir")

    common_parameter_checks(
        checks, label, h.params, h.documented, read_only=list(h.documented),
        constraints={"setup": ["eye_in_hand", "eye_to_hand"], "robot_source": ["tf", "topic"],
                     "target_source": ["image", "pose"]},
        refuse=["setup", "queue_size"])
    describe_all_check(checks, label, h.params)


# ---------------------------------------------------------------------------------------
# disparity_node

DISPARITY = "/stereo/disparity"
#: Rendered rectified pairs the disparity check replays.
DEPTH_FRAMES = 2


class Disparity:
    """disparity_node in /stereo, and rclpy around it: publishers of the rectified pairs
    and their camera_infos, a default reliable and a best-effort subscriber of
    disparity (stereo_msgs/DisparityImage)."""
    label, name, namespace = "disparity_node", "disparity_node", "/stereo"
    fqn = "/stereo/disparity_node"

    def __init__(self, peer, binary, params=None):
        self.peer = peer
        node = peer.node
        self.images = [node.create_publisher(Image, f"/stereo/{side}/image_rect", RELIABLE)
                       for side in ("left", "right")]
        self.infos = [node.create_publisher(CameraInfo, f"/stereo/{side}/camera_info", RELIABLE)
                      for side in ("left", "right")]
        self.reliable = peer.subscribe(DisparityImage, DISPARITY, RELIABLE)
        self.sensor = peer.subscribe(DisparityImage, DISPARITY, qos_profile_sensor_data)
        self.documented = {
            "stereo_algorithm": 1, "min_disparity": 0, "disparity_range": 64,
            "speckle_size": 100, "speckle_range": 2, "disp12_max_diff": 1,
            "uniqueness_ratio": 5.0, "P1": 10.0, "P2": 120.0, "sgbm_mode": 1,
            "refine_radius": 4, "approximate_sync": False,
            "approximate_sync_tolerance_seconds": 0.0, "queue_size": 5,
            "image_transport": "raw",
        }
        # stereocal depth matches with the library's defaults, stereo_image_proc's
        # differ in uniqueness_ratio, speckle_range and disp12_max_diff: given here.
        self.command = [binary, "--ros-args", "-r", "__ns:=/stereo", *(params or [
            "-p", "disparity_range:=64", "-p", "uniqueness_ratio:=5.0", "-p", "speckle_range:=2",
            "-p", "disp12_max_diff:=1"])]
        self.process = NodeProcess(self.command, peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)

    def received(self, stamp):
        got = [next((m for m in inbox.messages if stamp_of(m) == stamp), None)
               for inbox in (self.reliable, self.sensor)]
        return got if all(got) else None

    def send_until(self, pair, condition, what):
        def send():
            for publisher, info in zip(self.infos, pair[2:]):
                publisher.publish(info)
            for publisher, image in zip(self.images, pair[:2]):
                publisher.publish(image)
        return self.peer.send_until(send, condition, lambda: f"{what} (pair {stamp_of(pair[0])})")


def depth_session(stereocal, tmp):
    """Renders DEPTH_FRAMES rectified pairs (320x240) and runs `stereocal depth` on them:
    the pairs as rclpy messages, and the offline disparities by stamp (read by rosbags)."""
    out = Path(tmp)
    subprocess.run([stereocal, "synth", "--scene", "depth", "--out", str(out / "synth"),
                    "--frames", str(DEPTH_FRAMES), "--width", "320", "--height", "240"],
                   check=True, capture_output=True)
    subprocess.run([stereocal, "depth", "--bag", str(out / "synth" / "bag"),
                    "--out", str(out / "depth"), "--disparity-range", "64"],
                   check=True, capture_output=True)
    sides = {}
    for topic, msg in bag_messages(out / "synth" / "bag", [
            "/stereo/left/image_rect", "/stereo/right/image_rect",
            "/stereo/left/camera_info", "/stereo/right/camera_info"]):
        sides.setdefault(topic, []).append(msg)
    pairs = []
    for left, right, left_info, right_info in zip(
            sides["/stereo/left/image_rect"], sides["/stereo/right/image_rect"],
            sides["/stereo/left/camera_info"], sides["/stereo/right/camera_info"]):
        left_image, left_camera = rclpy_frame(left, left_info)
        right_image, right_camera = rclpy_frame(right, right_info)
        pairs.append((left_image, right_image, left_camera, right_camera))
    offline = {stamp_of(m): m for _, m in bag_messages(out / "depth", [DISPARITY])}
    return pairs, offline


def check_disparity(checks, peer, rosout, binary, stereocal):
    label = Disparity.label
    setup = f"setup: stereocal synth --scene depth ({DEPTH_FRAMES} pairs), stereocal depth"
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup) as note:
            pairs, offline = depth_session(stereocal, tmp)
            require(len(pairs) == DEPTH_FRAMES and len(offline) == DEPTH_FRAMES,
                    f"{len(pairs)} pairs in the bag, {len(offline)} offline disparities")
            note(f"{pairs[0][0].width}x{pairs[0][0].height} {pairs[0][0].encoding}")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no synthesized pairs")
        d = Disparity(peer, binary)
        try:
            disparity_checks(checks, peer, rosout, d, pairs, offline)
        finally:
            stop_and_check(checks, peer, d.process, label, d.name, d.namespace)


def disparity_checks(checks, peer, rosout, d, pairs, offline):
    label, fqn = d.label, d.fqn
    if not discovered(checks, peer, label, d.name, d.namespace):
        return checks.skip(label, "the other checks", "the node was not discovered")

    with checks.check(label, "graph: topics, services and their types"):
        graph_check(peer, d.name, d.namespace, {
            "publishers": {DISPARITY: ["stereo_msgs/msg/DisparityImage"],
                           "/rosout": ["rcl_interfaces/msg/Log"],
                           "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
            "subscribers": {f"/stereo/{side}/{name}": [kind]
                            for side in ("left", "right")
                            for name, kind in (("image_rect", "sensor_msgs/msg/Image"),
                                               ("camera_info", "sensor_msgs/msg/CameraInfo"))},
            "services": parameter_services(fqn),
            "clients": {},
        })

    session_check = (f"QoS: reliable and best-effort subscribers get the disparity of "
                     f"{DEPTH_FRAMES} pairs")
    answers = {}
    with checks.check(label, session_check) as note:
        peer.wait_until(lambda: all(p.get_subscription_count() > 0
                                    for p in (*d.images, *d.infos)),
                        "disparity_node's image and camera_info subscriptions")
        for pair in pairs:
            stamp = stamp_of(pair[0])
            answers[stamp] = d.send_until(pair, lambda: d.received(stamp),
                                          "disparity on both subscribers")
        note(f"received {d.reliable.count} (reliable), {d.sensor.count} (best-effort)")
    if not checks.passed(label, session_check):
        return checks.skip(label, "the other checks", "no disparities to check")

    with checks.check(label, "disparity: the left image's header, 32FC1, f, T, range, a "
                             "valid_window inside the image, equal to stereocal depth's") as note:
        for stamp, (reliable, sensor) in answers.items():
            want = offline[stamp]
            for msg in (reliable, sensor):
                require(msg.header.frame_id == want.header.frame_id,
                        f"pair {stamp}: frame_id {msg.header.frame_id!r}")
                require(msg.image.encoding == "32FC1" and msg.image.width == 320
                        and msg.image.height == 240 and msg.image.step == 4 * 320,
                        f"pair {stamp}: image {msg.image.encoding} {msg.image.width}x"
                        f"{msg.image.height} step {msg.image.step}")
                require((msg.f, msg.t, msg.min_disparity, msg.max_disparity, msg.delta_d)
                        == (want.f, want.t, want.min_disparity, want.max_disparity,
                            want.delta_d),
                        f"pair {stamp}: f {msg.f}, T {msg.t}, range {msg.min_disparity}.."
                        f"{msg.max_disparity}, delta_d {msg.delta_d}")
                window = msg.valid_window
                require(window.x_offset + window.width <= 320
                        and window.y_offset + window.height <= 240,
                        f"pair {stamp}: valid_window {window}")
                got = np.frombuffer(bytes(msg.image.data), dtype="<f4")
                require(np.array_equal(got, np.frombuffer(want.image.data.tobytes(), dtype="<f4")),
                        f"pair {stamp}: disparities differ from stereocal depth's")
            valid = np.frombuffer(bytes(reliable.image.data), dtype="<f4") >= reliable.min_disparity
            note(f"f {reliable.f:g} px, T {reliable.t:g} m, {valid.mean():.1%} valid")

    with checks.check(label, "a pair of a vertical rig: no disparity, the reason on "
                             "/rosout, the next pair matched") as note:
        bad = copy.deepcopy(pairs[0])
        bad_stamp = (100, 0)
        for msg in bad:
            msg.header = header(bad_stamp, msg.header.frame_id)
        bad[3].p = [*bad[3].p[:3], 0.0, *bad[3].p[4:7], -27.0, *bad[3].p[8:]]
        d.send_until(bad, lambda: any("vertical" in m.msg for m in rosout.messages
                                      if m.name.endswith("disparity_node")),
                     "a warning naming the vertical rig on /rosout")
        after = copy.deepcopy(pairs[1])
        after_stamp = (101, 0)
        for msg in after:
            msg.header = header(after_stamp, msg.header.frame_id)
        d.send_until(after, lambda: d.received(after_stamp), "the pair after")
        require(d.received(bad_stamp) is None and not any(
            stamp_of(m) == bad_stamp for m in d.reliable.messages),
            "a disparity was published for the vertical rig")
        note(next(m.msg for m in rosout.messages if "vertical" in m.msg))

    common_parameter_checks(
        checks, label, d.params, d.documented,
        read_only=list(d.documented),
        constraints={"image_transport": ["raw", "compressed"]},
        refuse=["disparity_range", "P2"])

    with checks.check(label, "parameters: disparity_range 5000 (out of range) refused at "
                             "start-up") as note:
        [descriptor] = d.params.describe(["disparity_range"])
        [described] = descriptor.integer_range
        require(not described.from_value <= 5000 <= described.to_value,
                f"5000 is within the described range {described}")
        refused = NodeProcess([*d.command, "-p", "disparity_range:=5000"], peer.domain)
        try:
            code = refused.process.wait(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            code = None
        refused.stop()
        require(code not in (None, 0) and "disparity_range" in refused.logs(),
                lambda: "disparity_node started with disparity_range:=5000: "
                        + ("still running" if code is None else f"exit code {code}")
                        + f"\n{refused.logs()[-2000:]}")
        note(f"described range {described.from_value}..{described.to_value} step "
             f"{described.step}; exit code {code}")

    describe_all_check(checks, label, d.params)


def check_disparity_bm(checks, peer, rosout, binary, stereocal):
    """disparity_node with `stereo_algorithm: 0` (block matching): the disparity of
    every rendered pair equal to `stereocal depth --algorithm bm`'s."""
    label = "disparity_node (block matching)"
    setup = f"setup: stereocal synth --scene depth ({DEPTH_FRAMES} pairs), stereocal depth --algorithm bm"
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup):
            pairs, _ = depth_session(stereocal, tmp)
            subprocess.run([stereocal, "depth", "--bag", str(Path(tmp) / "synth" / "bag"),
                            "--out", str(Path(tmp) / "bm"), "--algorithm", "bm",
                            "--disparity-range", "64"], check=True, capture_output=True)
            offline = {stamp_of(m): m for _, m in bag_messages(Path(tmp) / "bm", [DISPARITY])}
            require(len(offline) == DEPTH_FRAMES, f"{len(offline)} offline disparities")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no synthesized pairs")
        d = Disparity(peer, binary, ["-p", "stereo_algorithm:=0", "-p", "disparity_range:=64",
                                     "-p", "disp12_max_diff:=1"])
        try:
            if not discovered(checks, peer, label, d.name, d.namespace):
                return checks.skip(label, "the other checks", "the node was not discovered")
            what = "disparity of every pair equal to stereocal depth --algorithm bm's"
            with checks.check(label, what) as note:
                peer.wait_until(lambda: all(p.get_subscription_count() > 0
                                            for p in (*d.images, *d.infos)),
                                "disparity_node's image and camera_info subscriptions")
                for pair in pairs:
                    stamp = stamp_of(pair[0])
                    reliable, _ = d.send_until(pair, lambda stamp=stamp: d.received(stamp),
                                               "disparity on both subscribers")
                    got = np.frombuffer(bytes(reliable.image.data), dtype="<f4")
                    want = np.frombuffer(offline[stamp].image.data.tobytes(), dtype="<f4")
                    require(np.array_equal(got, want),
                            f"pair {stamp}: disparities differ from stereocal depth --algorithm bm's")
                note(f"{np.mean(got >= reliable.min_disparity):.1%} of the last pair's disparities valid")
        finally:
            stop_and_check(checks, peer, d.process, label, d.name, d.namespace)


# ---------------------------------------------------------------------------------------
# camera_node

CAMERA_NS = "/cam"


class Camera:
    """camera_node in /cam on its test pattern (CI has no video device), MJPEG decoded
    and passed through, and rclpy around it: a default reliable and a best-effort
    subscriber of image_raw, subscribers of image_raw/compressed, camera_info and
    ~/status, a set_camera_info client."""
    label, name, namespace = "camera_node", "camera_node", CAMERA_NS
    fqn = f"{CAMERA_NS}/camera_node"

    def __init__(self, peer, binary, tmp):
        self.peer = peer
        self.url_dir = Path(tmp)
        self.reliable = peer.subscribe(Image, f"{CAMERA_NS}/image_raw", RELIABLE, keep=30)
        self.sensor = peer.subscribe(Image, f"{CAMERA_NS}/image_raw", qos_profile_sensor_data,
                                     keep=30)
        self.compressed = peer.subscribe(CompressedImage, f"{CAMERA_NS}/image_raw/compressed",
                                         RELIABLE, keep=30)
        self.infos = peer.subscribe(CameraInfo, f"{CAMERA_NS}/camera_info", RELIABLE, keep=30)
        self.set_camera_info = peer.node.create_client(SetCameraInfo,
                                                       f"{CAMERA_NS}/set_camera_info")
        self.documented = {
            "use_sim_time": False, "video_device": "test_pattern", "pixel_format": "MJPEG",
            "image_width": 320, "image_height": 240, "framerate": 10.0,
            "frame_id": "cam_optical", "camera_name": "left",
            "camera_info_url": f"file://{tmp}/${{NAME}}.yaml", "output_encoding": "rgb8",
            "mjpeg_output": "both", "stereo_partner": "",
            "brightness": 0, "horizontal_flip": False,
        }
        self.command = [binary, "--ros-args", "-r", f"__ns:={CAMERA_NS}"]
        for name, value in self.documented.items():
            if name not in ("use_sim_time", "brightness", "horizontal_flip") and value != "":
                self.command += ["-p", f"{name}:={value}"]
        self.process = NodeProcess(self.command, peer.domain)
        peer.watch(self.process)
        self.params = Parameters(peer, self.fqn)

    def frame_after(self, stamp):
        """The first (image_raw, image_raw/compressed) of equal stamps after `stamp`."""
        jpegs = {stamp_of(m): m for m in self.compressed.messages}
        return next(((m, jpegs[stamp_of(m)]) for m in self.reliable.messages
                     if stamp_of(m) > stamp and stamp_of(m) in jpegs), None)


def rgb_of(msg):
    return np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.width, 3)


def check_camera(checks, peer, rosout, binary):
    with tempfile.TemporaryDirectory() as tmp:
        c = Camera(peer, binary, tmp)
        try:
            camera_checks(checks, peer, rosout, c)
        finally:
            stop_and_check(checks, peer, c.process, c.label, c.name, c.namespace)
        check_missing_camera(checks, peer, rosout, binary, tmp)


def camera_checks(checks, peer, rosout, c):
    label, fqn = c.label, c.fqn
    if not discovered(checks, peer, label, c.name, c.namespace):
        return checks.skip(label, "the other checks", "the node was not discovered")

    with checks.check(label, "graph: topics, services and their types"):
        graph_check(peer, c.name, c.namespace, {
            "publishers": {f"{CAMERA_NS}/image_raw": ["sensor_msgs/msg/Image"],
                           f"{CAMERA_NS}/image_raw/compressed":
                               ["sensor_msgs/msg/CompressedImage"],
                           f"{CAMERA_NS}/camera_info": ["sensor_msgs/msg/CameraInfo"],
                           f"{fqn}/status": ["std_msgs/msg/String"],
                           "/rosout": ["rcl_interfaces/msg/Log"],
                           "/parameter_events": ["rcl_interfaces/msg/ParameterEvent"]},
            "subscribers": {},
            "services": {**parameter_services(fqn),
                         f"{CAMERA_NS}/set_camera_info": ["sensor_msgs/srv/SetCameraInfo"]},
            "clients": {},
        })

    with checks.check(label, "QoS: reliable and best-effort subscribers get image_raw; "
                             "camera_info of each frame's stamp; stamps increasing, near "
                             "the wall clock") as note:
        peer.wait_until(lambda: c.reliable.count >= 5 and c.sensor.count >= 5,
                        "5 images on each subscriber")
        images = list(c.reliable.messages)
        stamps = [stamp_of(m) for m in images]
        require(stamps == sorted(stamps) and len(set(stamps)) == len(stamps),
                f"stamps not increasing: {stamps}")
        last = images[-1]
        require((last.encoding, last.width, last.height, last.step, last.header.frame_id)
                == ("rgb8", 320, 240, 960, "cam_optical"),
                f"image_raw {last.encoding} {last.width}x{last.height} step {last.step} "
                f"frame {last.header.frame_id!r}")
        age = time.time() - (last.header.stamp.sec + last.header.stamp.nanosec * 1e-9)
        require(0.0 <= age < TIMEOUT_S, f"the last image's stamp is {age:.3f} s old")
        info = peer.wait_until(lambda: next((m for m in c.infos.messages
                                             if stamp_of(m) == stamps[-1]), None),
                               "the camera_info of the last image's stamp")
        require((info.width, info.height) == (320, 240) and not any(info.k),
                f"uncalibrated camera_info {info.width}x{info.height} K {list(info.k)}")
        note(f"{c.reliable.count} (reliable), {c.sensor.count} (best-effort); "
             f"last stamp {age * 1e3:.0f} ms before reception")

    with checks.check(label, "MJPEG: image_raw/compressed is the device's JPEG, and "
                             "image_raw of the same stamp equals OpenCV's imdecode of it") \
            as note:
        image, jpeg = peer.wait_until(lambda: c.frame_after((0, 0)),
                                      "image_raw and image_raw/compressed of one stamp")
        require(jpeg.format == "rgb8; jpeg compressed bgr8", f"format {jpeg.format!r}")
        data = bytes(jpeg.data)
        require(data[:2] == b"\xff\xd8", "not a JPEG")
        decoded = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
        opencv = cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB).astype(int)
        diff = np.abs(rgb_of(image).astype(int) - opencv)
        require(diff.max() <= 2,
                f"|image_raw - OpenCV imdecode| mean {diff.mean():.3f}, max {diff.max()}")
        note(f"{len(data)} B JPEG; |image_raw - imdecode| mean {diff.mean():.3f}, "
             f"max {diff.max()}")

    common_parameter_checks(
        checks, label, c.params, c.documented,
        read_only=[n for n in c.documented if n not in ("brightness", "horizontal_flip")],
        constraints={"pixel_format": ["YUYV", "MJPEG", "GREY"],
                     "output_encoding": ["rgb8", "mono8"],
                     "mjpeg_output": ["raw", "compressed", "both"]},
        refuse=["image_width", "image_height"])

    with checks.check(label, "parameters: the V4L2 control brightness described with the "
                             "device's range, 100 (out of range) refused") as note:
        [descriptor] = c.params.describe(["brightness"])
        [described] = descriptor.integer_range
        require((described.from_value, described.to_value) == (-64, 64) and not
                descriptor.read_only, f"brightness {described}, read_only "
                f"{descriptor.read_only}")
        [result] = c.params.set({"brightness": 100})
        require(not result.successful and "out of range" in result.reason,
                f"set brightness=100: successful={result.successful}, {result.reason!r}")
        [now] = c.params.get(["brightness"])
        require(now == 0, f"brightness is {now} after a refused set")
        note(result.reason)

    with checks.check(label, "parameters: brightness 40 set while running brightens "
                             "image_raw") as note:
        def mean_after(stamp):
            frame = c.frame_after(stamp)
            return frame and (stamp_of(frame[0]), rgb_of(frame[0]).mean())
        before_stamp, before = peer.wait_until(lambda: mean_after((0, 0)), "a frame")
        [result] = c.params.set({"brightness": 40})
        require(result.successful, f"set brightness=40 refused: {result.reason!r}")
        _, after = peer.wait_until(
            lambda: (m := mean_after(before_stamp)) and m[1] > before + 20 and m,
            lambda: f"a frame brighter than {before:.1f} by 20")
        note(f"mean grey level {before:.1f} -> {after:.1f}")

    with checks.check(label, "set_camera_info: the file written before the answer, the "
                             "next camera_info carries it") as note:
        k = [300.0, 0.0, 159.5, 0.0, 301.0, 119.5, 0.0, 0.0, 1.0]
        request = SetCameraInfo.Request(camera_info=CameraInfo(
            width=320, height=240, distortion_model="plumb_bob",
            d=[-0.1, 0.02, 0.0, 0.0, 0.0], k=k, r=[1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0],
            p=[300.0, 0.0, 159.5, 0.0, 0.0, 301.0, 119.5, 0.0, 0.0, 0.0, 1.0, 0.0]))
        response = peer.call(c.set_camera_info, request)
        path = c.url_dir / "left.yaml"
        require(response.success, f"refused: {response.status_message!r}")
        written = yaml.safe_load(path.read_text())
        require(written["camera_name"] == "left" and written["camera_matrix"]["data"] == k
                and (written["image_width"], written["image_height"]) == (320, 240),
                f"{path}: {written}")
        peer.wait_until(lambda: any(list(m.k) == k for m in c.infos.messages),
                        "a camera_info with the new K")
        note(response.status_message)

    with checks.check(label, "~/status (transient local) to a late subscriber: streaming, "
                             "frames counted") as note:
        status = peer.subscribe(String, f"{fqn}/status", STATUS_QOS)
        last = peer.wait_until(
            lambda: status.last and json.loads(status.last.data)["camera_info"]["calibrated"]
            and json.loads(status.last.data),
            "a status saying the camera is calibrated")
        require(last["state"]["state"] == "streaming" and last["frames"]["captured"] > 0
                and last["frames"]["bad_frames"] == 0, f"status {last}")
        note(f"{last['state']['mode']}, {last['frames']['captured']} captured, "
             f"{last['published']} published")

    with checks.check(label, "/rosout: records of logger cam.camera_node"):
        peer.wait_until(lambda: any(m.name == "cam.camera_node" and "capturing" in m.msg
                                    for m in rosout.messages),
                        "a /rosout record of cam.camera_node saying what it captures")

    describe_all_check(checks, label, c.params)


def check_missing_camera(checks, peer, rosout, binary, tmp):
    """camera_node on a device that does not exist and a camera_info_url under a file:
    it keeps running, says why, and refuses set_camera_info with the reason."""
    label = "camera_node (missing device)"
    blocked = Path(tmp) / "blocked"
    blocked.write_text("a file, not a directory")
    command = [binary, "--ros-args", "-r", f"__ns:={CAMERA_NS}", "-p",
               "video_device:=/dev/stereocal-no-such-camera", "-p",
               f"camera_info_url:=file://{blocked}/${{NAME}}.yaml"]
    process = NodeProcess(command, peer.domain)
    peer.watch(process)
    try:
        with checks.check(label, "~/status and /rosout say why; the node keeps trying") as note:
            status = peer.subscribe(String, f"{CAMERA_NS}/camera_node/status", STATUS_QOS)
            last = peer.wait_until(
                lambda: status.last and (s := json.loads(status.last.data))["state"]["state"]
                == "waiting" and s["state"]["retry_in_s"] >= 1.0 and s,
                "a status waiting after a second attempt")
            require("cannot open /dev/stereocal-no-such-camera" in last["state"]["reason"],
                    f"reason {last['state']['reason']!r}")
            record = peer.wait_until(
                lambda: next((m for m in rosout.messages if m.name == "cam.camera_node"
                              and "trying again" in m.msg), None),
                "a /rosout record saying it tries again")
            require(record.level == Log.ERROR, f"level {record.level}: {record.msg}")
            note(last["state"]["reason"])
        with checks.check(label, "set_camera_info to an unwritable camera_info_url refused "
                                 "with the reason") as note:
            client = peer.node.create_client(SetCameraInfo, f"{CAMERA_NS}/set_camera_info")
            response = peer.call(client, SetCameraInfo.Request(camera_info=CameraInfo(
                width=640, height=480, distortion_model="plumb_bob", d=[0.0] * 5,
                k=[500.0, 0, 319.5, 0, 500.0, 239.5, 0, 0, 1.0])))
            require(not response.success and "calibration not stored" in response.status_message
                    and f"{blocked}/camera.yaml" in response.status_message,
                    f"success={response.success}: {response.status_message!r}")
            note(response.status_message)
    finally:
        stop_and_check(checks, peer, process, label, "camera_node", CAMERA_NS)


# ---------------------------------------------------------------------------------------
# point_cloud_node

POINTS2 = "/stereo/points2"
#: stereo_image_proc's four layouts: (use_color, avoid_point_cloud_padding) -> fields
#: (name, offset) and bytes a point.
CLOUD_LAYOUTS = {
    (True, False): ([("x", 0), ("y", 4), ("z", 8), ("rgb", 16)], 32),
    (False, False): ([("x", 0), ("y", 4), ("z", 8)], 16),
    (True, True): ([("x", 0), ("y", 4), ("z", 8), ("rgb", 12)], 16),
    (False, True): ([("x", 0), ("y", 4), ("z", 8)], 12),
}


def xyz_of(cloud):
    """The x, y, z of every point of an organized PointCloud2 (float32 fields)."""
    offsets = {f.name: f.offset for f in cloud.fields}
    raw = np.frombuffer(bytes(cloud.data), dtype=np.uint8).reshape(-1, cloud.point_step)
    return np.stack([raw[:, offsets[n]:offsets[n] + 4].copy().view("<f4")[:, 0]
                     for n in ("x", "y", "z")], axis=1)


def check_point_cloud(checks, peer, rosout, disparity_binary, cloud_binary, stereocal):
    label = "point_cloud_node"
    setup = f"setup: stereocal synth --scene depth ({DEPTH_FRAMES} pairs), stereocal depth"
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup):
            pairs, _ = depth_session(stereocal, tmp)
            offline = {stamp_of(m): m for _, m in bag_messages(Path(tmp) / "depth", [POINTS2])}
            require(len(offline) == DEPTH_FRAMES, f"{len(offline)} offline clouds")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no synthesized pairs")
        d = Disparity(peer, disparity_binary)
        try:
            for index, ((color, avoid), (fields, step)) in enumerate(CLOUD_LAYOUTS.items()):
                what = (f"points2 (use_color {str(color).lower()}, avoid_point_cloud_padding "
                        f"{str(avoid).lower()}): reliable and best-effort, fields "
                        f"{[name for name, _ in fields]}, {step} bytes a point, xyz equal to "
                        f"stereocal depth's")
                command = [cloud_binary, "--ros-args", "-r", "__ns:=/stereo",
                           "-r", "left/image_rect_color:=left/image_rect",
                           "-p", f"use_color:={str(color).lower()}",
                           "-p", f"avoid_point_cloud_padding:={str(avoid).lower()}"]
                process = NodeProcess(command, peer.domain)
                peer.watch(process)
                reliable = peer.subscribe(PointCloud2, POINTS2, RELIABLE)
                sensor = peer.subscribe(PointCloud2, POINTS2, qos_profile_sensor_data)
                try:
                    with checks.check(label, what) as note:
                        pair = pairs[0]
                        stamp = stamp_of(pair[0])

                        def both():
                            got = [next((m for m in inbox.messages if stamp_of(m) == stamp), None)
                                   for inbox in (reliable, sensor)]
                            return got if all(got) else None
                        got = d.send_until(pair, both, "points2 on both subscribers")
                        for msg in got:
                            require([(f.name, f.offset, f.datatype, f.count) for f in msg.fields]
                                    == [(n, o, PointField.FLOAT32, 1) for n, o in fields],
                                    f"fields {msg.fields}")
                            require(msg.point_step == step and msg.row_step == step * msg.width
                                    and (msg.width, msg.height) == (320, 240)
                                    and not msg.is_dense,
                                    f"step {msg.point_step}, row_step {msg.row_step}, "
                                    f"{msg.width}x{msg.height}, is_dense {msg.is_dense}")
                            ours, want = xyz_of(msg), xyz_of(offline[stamp])
                            same = np.array_equal(np.isnan(ours), np.isnan(want)) and np.array_equal(
                                ours[~np.isnan(ours)], want[~np.isnan(want)])
                            require(same, "xyz differ from stereocal depth's points2")
                        valid = ~np.isnan(xyz_of(got[0])[:, 2])
                        note(f"{valid.mean():.1%} of the points valid")
                finally:
                    peer.node.destroy_subscription(reliable.subscription)
                    peer.node.destroy_subscription(sensor.subscription)
                    stop_and_check(checks, peer, process, f"{label} (layout {index + 1})",
                                   "point_cloud_node", "/stereo")
        finally:
            stop_and_check(checks, peer, d.process, f"{d.label} (for {label})", d.name,
                           d.namespace)


# ---------------------------------------------------------------------------------------
# the whole stereo pipeline, composed

#: Raw stereo frames replayed through the composed pipeline.
PIPELINE_FRAMES = 3
#: disparity_node's arguments that make it match as `stereocal depth` does (the library's
#: defaults where stereo_image_proc's differ), at 64 disparities.
MATCH_AS_OFFLINE = ["-p", "disparity_range:=64", "-p", "uniqueness_ratio:=5.0",
                    "-p", "speckle_range:=2", "-p", "disp12_max_diff:=1"]


def pipeline_session(stereocal, tmp):
    """Renders a raw (distorted, unrectified) stereo session, 320x240 mono8, and runs
    `stereocal rectify` then `stereocal depth` on it: the raw frames as rclpy messages
    (left image, right image, left camera_info, right camera_info) and the offline
    disparities and clouds by stamp (read by rosbags)."""
    out = Path(tmp)
    for command in (
            ["synth", "--scene", "stereo", "--out", str(out / "raw"), "--frames",
             str(PIPELINE_FRAMES), "--width", "320", "--height", "240"],
            ["rectify", "--bag", str(out / "raw" / "bag"), "--out", str(out / "rect")],
            ["depth", "--bag", str(out / "rect"), "--out", str(out / "depth"),
             "--disparity-range", "64"]):
        subprocess.run([stereocal, *command], check=True, capture_output=True)
    sides = {}
    for topic, msg in bag_messages(out / "raw" / "bag", [
            "/stereo/left/image_raw", "/stereo/right/image_raw",
            "/stereo/left/camera_info", "/stereo/right/camera_info"]):
        sides.setdefault(topic, []).append(msg)
    frames = []
    for left, right, left_info, right_info in zip(
            sides["/stereo/left/image_raw"], sides["/stereo/right/image_raw"],
            sides["/stereo/left/camera_info"], sides["/stereo/right/camera_info"]):
        left_image, left_camera = rclpy_frame(left, left_info)
        right_image, right_camera = rclpy_frame(right, right_info)
        frames.append((left_image, right_image, left_camera, right_camera))
    disparities = {stamp_of(m): m for _, m in bag_messages(out / "depth", [DISPARITY])}
    clouds = {stamp_of(m): m for _, m in bag_messages(out / "depth", [POINTS2])}
    return frames, disparities, clouds


def check_pipeline(checks, peer, rosout, stereocal):
    """rectify_node x2, disparity_node and point_cloud_node in one `stereocal node
    compose` process, fed raw frames from rclpy: disparity and points2 equal to
    `stereocal rectify` + `stereocal depth` on the same frames."""
    label = "pipeline (composed)"
    setup = (f"setup: stereocal synth --scene stereo ({PIPELINE_FRAMES} raw pairs), "
             f"stereocal rectify, stereocal depth")
    with tempfile.TemporaryDirectory() as tmp:
        with checks.check(label, setup) as note:
            frames, disparities, clouds = pipeline_session(stereocal, tmp)
            require(len(frames) == PIPELINE_FRAMES and len(disparities) == PIPELINE_FRAMES
                    and len(clouds) == PIPELINE_FRAMES,
                    f"{len(frames)} raw pairs, {len(disparities)} offline disparities, "
                    f"{len(clouds)} offline clouds")
            note(f"{frames[0][0].width}x{frames[0][0].height} {frames[0][0].encoding}, "
                 f"{frames[0][2].distortion_model}")
        if not checks.passed(label, setup):
            return checks.skip(label, "the other checks", "no rendered session")
        composition = Path(tmp) / "pipeline.yaml"
        composition.write_text(yaml.safe_dump({"nodes": [
            {"node": "rectify", "args": ["-r", "__ns:=/stereo/left", "-r", "image:=image_raw"]},
            {"node": "rectify", "args": ["-r", "__ns:=/stereo/right", "-r", "image:=image_raw"]},
            {"node": "disparity", "args": ["-r", "__ns:=/stereo", *MATCH_AS_OFFLINE]},
            {"node": "point_cloud",
             "args": ["-r", "__ns:=/stereo", "-r", "left/image_rect_color:=left/image_rect"]},
        ]}))
        images = [peer.node.create_publisher(Image, f"/stereo/{side}/image_raw", RELIABLE)
                  for side in ("left", "right")]
        infos = [peer.node.create_publisher(CameraInfo, f"/stereo/{side}/camera_info", RELIABLE)
                 for side in ("left", "right")]
        disparity_inbox = peer.subscribe(DisparityImage, DISPARITY, RELIABLE)
        cloud_inbox = peer.subscribe(PointCloud2, POINTS2, RELIABLE)
        process = NodeProcess([stereocal, "node", "compose", str(composition)], peer.domain)
        peer.watch(process)
        nodes = [("rectify_node", "/stereo/left"), ("rectify_node", "/stereo/right"),
                 ("disparity_node", "/stereo"), ("point_cloud_node", "/stereo")]
        try:
            with checks.check(label, "discovery: the four nodes of the one process") as note:
                peer.wait_until(lambda: all(n in peer.node_names() for n in nodes),
                                f"{nodes} in get_node_names_and_namespaces()")
                note(", ".join(f"{ns}/{name}" for name, ns in nodes))

            replay = (f"raw pairs replayed: disparity and points2 of every pair, equal to "
                      f"stereocal rectify + stereocal depth's")
            with checks.check(label, replay) as note:
                peer.wait_until(lambda: all(p.get_subscription_count() > 0
                                            for p in (*images, *infos)),
                                "the rectify nodes' subscriptions")
                for frame in frames:
                    stamp = stamp_of(frame[0])

                    def send(frame=frame):
                        for publisher, info in zip(infos, frame[2:]):
                            publisher.publish(info)
                        for publisher, image in zip(images, frame[:2]):
                            publisher.publish(image)

                    def both(stamp=stamp):
                        got = [next((m for m in inbox.messages if stamp_of(m) == stamp), None)
                               for inbox in (disparity_inbox, cloud_inbox)]
                        return got if all(got) else None
                    disparity, cloud = peer.send_until(
                        send, both, lambda stamp=stamp: f"disparity and points2 of pair {stamp}")
                    want = disparities[stamp]
                    got = np.frombuffer(bytes(disparity.image.data), dtype="<f4")
                    require(np.array_equal(got, np.frombuffer(want.image.data.tobytes(),
                                                              dtype="<f4")),
                            f"pair {stamp}: disparities differ from stereocal depth's")
                    require((disparity.f, disparity.t) == (want.f, want.t),
                            f"pair {stamp}: f {disparity.f}, T {disparity.t}")
                    ours, theirs = xyz_of(cloud), xyz_of(clouds[stamp])
                    require(np.array_equal(np.isnan(ours), np.isnan(theirs))
                            and np.array_equal(ours[~np.isnan(ours)], theirs[~np.isnan(theirs)]),
                            f"pair {stamp}: xyz differ from stereocal depth's points2")
                valid = got >= disparity.min_disparity
                note(f"{len(frames)} pairs; last: {valid.mean():.1%} of the disparities valid")
        finally:
            for publisher in (*images, *infos):
                peer.node.destroy_publisher(publisher)
            for inbox in (disparity_inbox, cloud_inbox):
                peer.node.destroy_subscription(inbox.subscription)
            stop_and_check(checks, peer, process, label, "disparity_node", "/stereo")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rectify-node", default=str(ROOT / "target" / "debug" / "rectify_node"))
    parser.add_argument("--calibrate-node",
                        default=str(ROOT / "target" / "debug" / "calibrate_node"))
    parser.add_argument("--pose-node", default=str(ROOT / "target" / "debug" / "pose_node"))
    parser.add_argument("--handeye-node",
                        default=str(ROOT / "target" / "debug" / "handeye_node"))
    parser.add_argument("--disparity-node",
                        default=str(ROOT / "target" / "debug" / "disparity_node"))
    parser.add_argument("--point-cloud-node",
                        default=str(ROOT / "target" / "debug" / "point_cloud_node"))
    parser.add_argument("--camera-node",
                        default=str(ROOT / "target" / "debug" / "camera_node"))
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "debug" / "stereocal"))
    parser.add_argument("--only", choices=("rectify", "calibrate", "pose", "handeye", "disparity",
                                           "point_cloud", "pipeline", "camera"))
    parser.add_argument("--fastdds-socket-buffer", type=int, default=8 * 1024 * 1024,
                        help="bytes of Fast DDS's UDP socket buffers; 0 keeps its default")
    args = parser.parse_args()
    for binary in (args.rectify_node, args.calibrate_node, args.pose_node, args.handeye_node,
                   args.disparity_node, args.point_cloud_node, args.camera_node,
                   args.stereocal):
        if not Path(binary).exists():
            raise SystemExit(f"{binary} not found; build it with `cargo build --bin rectify_node "
                             "--bin calibrate_node --bin pose_node --bin handeye_node "
                             "--bin disparity_node --bin point_cloud_node --bin camera_node "
                             "--bin stereocal`")

    def run(checks):
        lease = DomainLease()
        peer = Peer(lease.id, socket_buffer=args.fastdds_socket_buffer)
        print(f"rclpy {peer.rmw} on ROS domain {lease.id}", flush=True)
        rosout = peer.subscribe(Log, "/rosout", qos_profile_rosout_default)
        try:
            if args.only in (None, "rectify"):
                check_rectify(checks, peer, rosout, args.rectify_node)
                check_rectify_compressed(checks, peer, rosout, args.rectify_node)
            if args.only in (None, "calibrate"):
                check_calibrate(checks, peer, rosout, args.calibrate_node, args.stereocal)
            if args.only in (None, "pose"):
                check_pose(checks, peer, rosout, args.pose_node, args.stereocal)
            if args.only in (None, "handeye"):
                check_handeye(checks, peer, rosout, args.handeye_node, args.stereocal)
            if args.only in (None, "disparity"):
                check_disparity(checks, peer, rosout, args.disparity_node, args.stereocal)
                check_disparity_bm(checks, peer, rosout, args.disparity_node, args.stereocal)
            if args.only in (None, "point_cloud"):
                check_point_cloud(checks, peer, rosout, args.disparity_node,
                                  args.point_cloud_node, args.stereocal)
            if args.only in (None, "pipeline"):
                check_pipeline(checks, peer, rosout, args.stereocal)
            if args.only in (None, "camera"):
                check_camera(checks, peer, rosout, args.camera_node)
        finally:
            peer.close()
            lease.release()

    main_guard(run)


if __name__ == "__main__":
    main()
