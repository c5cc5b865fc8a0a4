"""ROS 2 over Cyclone DDS's Python binding, for the checks that talk to stereocal's nodes.

IDL types declared with ROS 2's DDS type names (such as `sensor_msgs::msg::dds_::Image_`,
and `tf2_msgs::msg::dds_::TFMessage_`, which no rclpy wheel provides) so that Cyclone
DDS reads and writes the same topics as a ROS 2 node, the QoS they use (reliable, plain
CDR as ROS 2 uses), and stopping a node process with SIGTERM.
"""

import signal
import subprocess
import sys
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import array, float64, int32, sequence, uint8, uint32
from cyclonedds.util import duration


@final
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@final
@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@final
@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]


@final
@dataclass
class RegionOfInterest(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32
    y_offset: uint32
    height: uint32
    width: uint32
    do_rectify: bool


@final
@dataclass
class CameraInfo(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Header
    height: uint32
    width: uint32
    distortion_model: str
    d: sequence[float64]
    k: array[float64, 9]
    r: array[float64, 9]
    p: array[float64, 12]
    binning_x: uint32
    binning_y: uint32
    roi: RegionOfInterest


@final
@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@final
@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@final
@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@final
@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@final
@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@final
@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@final
@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@final
@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@final
@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


def fail(message):
    """Prints `FAIL: message` on stderr and exits with status 1."""
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def reliable_qos(depth, transient_local=False):
    """Reliable (1 s blocking), keep-last `depth`, plain CDR; transient local if asked."""
    policies = [Policy.Reliability.Reliable(duration(seconds=1))]
    if transient_local:
        policies.append(Policy.Durability.TransientLocal)
    policies += [
        Policy.History.KeepLast(depth),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    ]
    return Qos(*policies)


def stop_node(node, name):
    """Sends SIGTERM to the `node` process if it still runs and waits up to 10 s for it.

    Returns what it wrote on stderr; fails the check, killing it, when it does not stop.
    """
    if node.poll() is None:
        node.send_signal(signal.SIGTERM)
    try:
        _, stderr = node.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        node.kill()
        fail(f"{name} did not stop on SIGTERM")
    return stderr
