"""ros2msg schema texts of stereocal-msgs types, generated independently by `rosbags`.

rosbags' ROS 2 Humble typestore generates the complete message definition of a type
(its fields, then each dependency after a line of 80 '=' and `MSG: pkg/Type`), the
text rosbag2 stores in MCAP schemas with encoding `ros2msg`. This script writes them
to msgs/tests/fixtures/<pkg>__msg__<Type>.ros2msg (`--write`) or compares with the
stored ones; msgs/tests/schemas.rs asserts that `RosMessage::schema_text()` equals them.

Usage: .venv/bin/python interop/check_msgs_schemas.py [--write]
"""

import argparse
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_typestore

FIXTURES = Path(__file__).resolve().parent.parent / 'msgs' / 'tests' / 'fixtures'

TYPES = [
    'builtin_interfaces/msg/Time',
    'std_msgs/msg/Header',
    'std_msgs/msg/String',
    'sensor_msgs/msg/Image',
    'sensor_msgs/msg/CompressedImage',
    'sensor_msgs/msg/RegionOfInterest',
    'sensor_msgs/msg/CameraInfo',
    'sensor_msgs/msg/PointField',
    'sensor_msgs/msg/PointCloud2',
    'geometry_msgs/msg/Vector3',
    'geometry_msgs/msg/Point',
    'geometry_msgs/msg/Quaternion',
    'geometry_msgs/msg/Pose',
    'geometry_msgs/msg/PoseStamped',
    'geometry_msgs/msg/PoseWithCovariance',
    'geometry_msgs/msg/PoseWithCovarianceStamped',
    'geometry_msgs/msg/Transform',
    'geometry_msgs/msg/TransformStamped',
    'tf2_msgs/msg/TFMessage',
    'stereo_msgs/msg/DisparityImage',
    'rosgraph_msgs/msg/Clock',
    'rcl_interfaces/msg/ParameterValue',
    'rcl_interfaces/msg/Parameter',
    'rcl_interfaces/msg/ParameterDescriptor',
    'rcl_interfaces/msg/SetParametersResult',
    'rcl_interfaces/msg/ListParametersResult',
    'rcl_interfaces/msg/ParameterEvent',
]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--write', action='store_true', help='regenerate the fixtures')
    args = parser.parse_args()
    ts = get_typestore(Stores.ROS2_HUMBLE)
    failures = 0
    for typename in TYPES:
        text, _ = ts.generate_msgdef(typename, ros_version=2)
        path = FIXTURES / (typename.replace('/', '__') + '.ros2msg')
        if args.write:
            FIXTURES.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f'wrote {path.name}')
            continue
        stored = path.read_text() if path.exists() else None
        failures += stored != text
        print(f'{typename:40} {"ok" if stored == text else "DIFFERS"}')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
