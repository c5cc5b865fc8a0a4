"""CDR bytes of stereocal-msgs types, produced independently by the `rosbags` library.

Builds one sample of every message type stereocal-msgs defines, serializes it with
rosbags' ROS 2 Humble typestore (`serialize_cdr`), and compares with the fixtures in
msgs/tests/fixtures/ (`--write` regenerates them). The Rust tests in
msgs/tests/cdr_fixtures.rs build the same samples and assert identical bytes.

Services are not in rosbags' typestore: their request/response types are registered
from their .msg field text; the empty Trigger request uses std_msgs/Empty, which
follows the same IDL rule (one placeholder byte).

Usage: .venv/bin/python interop/check_msgs_cdr.py [--write]
"""

import argparse
import sys
from pathlib import Path

import numpy as np
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

FIXTURES = Path(__file__).resolve().parent.parent / 'msgs' / 'tests' / 'fixtures'

ts = get_typestore(Stores.ROS2_HUMBLE)
ts.register(get_types_from_msg('sensor_msgs/CameraInfo camera_info', 'sensor_msgs/msg/SetCameraInfo_Request'))
ts.register(get_types_from_msg('bool success\nstring status_message', 'sensor_msgs/msg/SetCameraInfo_Response'))
ts.register(get_types_from_msg('bool success\nstring message', 'std_srvs/msg/Trigger_Response'))
for name, fields in {
    'ListParameters_Request': 'string[] prefixes\nuint64 depth',
    'ListParameters_Response': 'rcl_interfaces/ListParametersResult result',
    'GetParameters_Request': 'string[] names',
    'GetParameters_Response': 'rcl_interfaces/ParameterValue[] values',
    'GetParameterTypes_Response': 'uint8[] types',
    'SetParameters_Request': 'rcl_interfaces/Parameter[] parameters',
    'SetParameters_Response': 'rcl_interfaces/SetParametersResult[] results',
    'SetParametersAtomically_Response': 'rcl_interfaces/SetParametersResult result',
    'DescribeParameters_Response': 'rcl_interfaces/ParameterDescriptor[] descriptors',
}.items():
    ts.register(get_types_from_msg(fields, f'rcl_interfaces/msg/{name}'))
T = ts.types


def time():
    return T['builtin_interfaces/msg/Time'](sec=1700000000, nanosec=123456789)


def header(frame_id):
    return T['std_msgs/msg/Header'](stamp=time(), frame_id=frame_id)


def roi():
    return T['sensor_msgs/msg/RegionOfInterest'](x_offset=1, y_offset=2, height=3, width=4, do_rectify=True)


def image():
    return T['sensor_msgs/msg/Image'](
        header=header('cam'), height=2, width=3, encoding='rgb8', is_bigendian=0, step=9,
        data=np.arange(18, dtype=np.uint8))


def camera_info():
    return T['sensor_msgs/msg/CameraInfo'](
        header=header('left'), height=480, width=640, distortion_model='plumb_bob',
        d=np.array([-0.1, 0.01, 0.001, -0.002, 0.0003]),
        k=np.array([500.0, 0.0, 319.5, 0.0, 501.0, 239.5, 0.0, 0.0, 1.0]),
        r=np.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
        p=np.array([500.0, 0.0, 319.5, -30.0, 0.0, 501.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]),
        binning_x=1, binning_y=2,
        roi=T['sensor_msgs/msg/RegionOfInterest'](x_offset=10, y_offset=20, height=30, width=40, do_rectify=True))


def point_cloud2():
    points = np.zeros(4, dtype=[('x', '<f4'), ('y', '<f4'), ('z', '<f4'), ('intensity', '<u2'), ('pad', '<u2')])
    points['x'] = [0.5, 1.0, -1.5, np.nan]
    points['y'] = [-0.25, 0.0, 0.75, np.nan]
    points['z'] = [1.5, 2.0, 3.0, np.nan]
    points['intensity'] = [100, 200, 300, 0]
    field = T['sensor_msgs/msg/PointField']
    return T['sensor_msgs/msg/PointCloud2'](
        header=header('left_optical'), height=2, width=2,
        fields=[field(name='x', offset=0, datatype=field.FLOAT32, count=1),
                field(name='y', offset=4, datatype=field.FLOAT32, count=1),
                field(name='z', offset=8, datatype=field.FLOAT32, count=1),
                field(name='intensity', offset=12, datatype=field.UINT16, count=1)],
        is_bigendian=False, point_step=16, row_step=32, data=points.view(np.uint8), is_dense=False)


def vector3():
    return T['geometry_msgs/msg/Vector3'](x=1.5, y=-2.25, z=3.0)


def point():
    return T['geometry_msgs/msg/Point'](x=0.1, y=0.2, z=0.3)


def quaternion():
    return T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.6, w=0.8)


def pose():
    return T['geometry_msgs/msg/Pose'](position=point(), orientation=quaternion())


def transform():
    return T['geometry_msgs/msg/Transform'](translation=vector3(), rotation=quaternion())


def parameter_value(kind, **value):
    fields = dict(
        type=kind, bool_value=False, integer_value=0, double_value=0.0, string_value='',
        byte_array_value=np.array([], dtype=np.uint8), bool_array_value=np.array([], dtype=bool),
        integer_array_value=np.array([], dtype=np.int64), double_array_value=np.array([], dtype=np.float64),
        string_array_value=[])
    fields.update(value)
    return T['rcl_interfaces/msg/ParameterValue'](**fields)


def parameters():
    return [
        T['rcl_interfaces/msg/Parameter'](name='interpolation', value=parameter_value(2, integer_value=-3)),
        T['rcl_interfaces/msg/Parameter'](name='camera.gains', value=parameter_value(
            8, double_array_value=np.array([0.5, -1.25]))),
        T['rcl_interfaces/msg/Parameter'](name='names', value=parameter_value(9, string_array_value=['a', 'bc'])),
        T['rcl_interfaces/msg/Parameter'](name='mask', value=parameter_value(
            5, byte_array_value=np.array([1, 255], dtype=np.uint8))),
        T['rcl_interfaces/msg/Parameter'](name='flags', value=parameter_value(
            6, bool_array_value=np.array([True, False]))),
        T['rcl_interfaces/msg/Parameter'](name='ids', value=parameter_value(
            7, integer_array_value=np.array([4, -5], dtype=np.int64))),
    ]


def descriptors():
    return [
        T['rcl_interfaces/msg/ParameterDescriptor'](
            name='interpolation', type=2, description='0 nearest, 1 linear', additional_constraints='',
            read_only=False, dynamic_typing=False, floating_point_range=[],
            integer_range=[T['rcl_interfaces/msg/IntegerRange'](from_value=0, to_value=2, step=1)]),
        T['rcl_interfaces/msg/ParameterDescriptor'](
            name='square', type=3, description='metres', additional_constraints='one of: a, b',
            read_only=True, dynamic_typing=False,
            floating_point_range=[T['rcl_interfaces/msg/FloatingPointRange'](from_value=0.0, to_value=1.5, step=0.0)],
            integer_range=[]),
    ]


def pose_with_covariance():
    covariance = np.arange(36, dtype=np.float64) * 0.25 - 3.0
    return T['geometry_msgs/msg/PoseWithCovariance'](pose=pose(), covariance=covariance)


def transform_stamped(child):
    return T['geometry_msgs/msg/TransformStamped'](header=header('base'), child_frame_id=child, transform=transform())


SAMPLES = {
    'builtin_interfaces__msg__Time': ('builtin_interfaces/msg/Time', time()),
    'std_msgs__msg__Header': ('std_msgs/msg/Header', header('left_optical')),
    'std_msgs__msg__String': ('std_msgs/msg/String', T['std_msgs/msg/String'](data='{"samples": 3}')),
    'sensor_msgs__msg__Image': ('sensor_msgs/msg/Image', image()),
    'sensor_msgs__msg__CompressedImage': ('sensor_msgs/msg/CompressedImage', T['sensor_msgs/msg/CompressedImage'](
        header=header('cam'), format='png', data=np.array([137, 80, 78, 71, 1, 2, 3], dtype=np.uint8))),
    'sensor_msgs__msg__RegionOfInterest': ('sensor_msgs/msg/RegionOfInterest', roi()),
    'sensor_msgs__msg__CameraInfo': ('sensor_msgs/msg/CameraInfo', camera_info()),
    'sensor_msgs__msg__PointField': ('sensor_msgs/msg/PointField', T['sensor_msgs/msg/PointField'](
        name='normal', offset=16, datatype=T['sensor_msgs/msg/PointField'].FLOAT32, count=3)),
    'sensor_msgs__msg__PointCloud2': ('sensor_msgs/msg/PointCloud2', point_cloud2()),
    'geometry_msgs__msg__Vector3': ('geometry_msgs/msg/Vector3', vector3()),
    'geometry_msgs__msg__Point': ('geometry_msgs/msg/Point', point()),
    'geometry_msgs__msg__Quaternion': ('geometry_msgs/msg/Quaternion', quaternion()),
    'geometry_msgs__msg__Pose': ('geometry_msgs/msg/Pose', pose()),
    'geometry_msgs__msg__PoseStamped': ('geometry_msgs/msg/PoseStamped',
                                        T['geometry_msgs/msg/PoseStamped'](header=header('base'), pose=pose())),
    'geometry_msgs__msg__PoseWithCovariance': ('geometry_msgs/msg/PoseWithCovariance', pose_with_covariance()),
    'geometry_msgs__msg__PoseWithCovarianceStamped': ('geometry_msgs/msg/PoseWithCovarianceStamped',
                                                      T['geometry_msgs/msg/PoseWithCovarianceStamped'](
                                                          header=header('camera'), pose=pose_with_covariance())),
    'geometry_msgs__msg__Transform': ('geometry_msgs/msg/Transform', transform()),
    'geometry_msgs__msg__TransformStamped': ('geometry_msgs/msg/TransformStamped', transform_stamped('tool0')),
    'tf2_msgs__msg__TFMessage': ('tf2_msgs/msg/TFMessage', T['tf2_msgs/msg/TFMessage'](
        transforms=[transform_stamped('tool0'), transform_stamped('camera')])),
    'stereo_msgs__msg__DisparityImage': ('stereo_msgs/msg/DisparityImage', T['stereo_msgs/msg/DisparityImage'](
        header=header('left'),
        image=T['sensor_msgs/msg/Image'](
            header=header('left'), height=2, width=2, encoding='32FC1', is_bigendian=0, step=8,
            data=np.array([1.0, 2.5, -1.0, 64.0], dtype='<f4').view(np.uint8)),
        f=500.0, t=0.12, valid_window=roi(), min_disparity=0.0, max_disparity=64.0, delta_d=0.0625)),
    'sensor_msgs__srv__SetCameraInfo_Request': ('sensor_msgs/msg/SetCameraInfo_Request',
                                                T['sensor_msgs/msg/SetCameraInfo_Request'](camera_info=camera_info())),
    'sensor_msgs__srv__SetCameraInfo_Response': ('sensor_msgs/msg/SetCameraInfo_Response',
                                                 T['sensor_msgs/msg/SetCameraInfo_Response'](success=True, status_message='stored')),
    'std_srvs__srv__Trigger_Request': ('std_msgs/msg/Empty', T['std_msgs/msg/Empty']()),
    'rosgraph_msgs__msg__Clock': ('rosgraph_msgs/msg/Clock', T['rosgraph_msgs/msg/Clock'](clock=time())),
    'rcl_interfaces__msg__ParameterEvent': ('rcl_interfaces/msg/ParameterEvent', T['rcl_interfaces/msg/ParameterEvent'](
        stamp=time(), node='/left/rectify_node', new_parameters=parameters()[:1],
        changed_parameters=parameters()[1:], deleted_parameters=[])),
    'rcl_interfaces__srv__ListParameters_Request': ('rcl_interfaces/msg/ListParameters_Request',
                                                    T['rcl_interfaces/msg/ListParameters_Request'](
                                                        prefixes=['camera'], depth=2)),
    'rcl_interfaces__srv__ListParameters_Response': ('rcl_interfaces/msg/ListParameters_Response',
                                                     T['rcl_interfaces/msg/ListParameters_Response'](
                                                         result=T['rcl_interfaces/msg/ListParametersResult'](
                                                             names=['camera.gains', 'queue_size'],
                                                             prefixes=['camera']))),
    'rcl_interfaces__srv__GetParameters_Request': ('rcl_interfaces/msg/GetParameters_Request',
                                                   T['rcl_interfaces/msg/GetParameters_Request'](
                                                       names=['interpolation', 'nope'])),
    'rcl_interfaces__srv__GetParameters_Response': ('rcl_interfaces/msg/GetParameters_Response',
                                                    T['rcl_interfaces/msg/GetParameters_Response'](
                                                        values=[p.value for p in parameters()] + [parameter_value(0)])),
    'rcl_interfaces__srv__GetParameterTypes_Response': ('rcl_interfaces/msg/GetParameterTypes_Response',
                                                        T['rcl_interfaces/msg/GetParameterTypes_Response'](
                                                            types=np.array([2, 8, 0], dtype=np.uint8))),
    'rcl_interfaces__srv__SetParameters_Request': ('rcl_interfaces/msg/SetParameters_Request',
                                                   T['rcl_interfaces/msg/SetParameters_Request'](
                                                       parameters=parameters())),
    'rcl_interfaces__srv__SetParameters_Response': ('rcl_interfaces/msg/SetParameters_Response',
                                                    T['rcl_interfaces/msg/SetParameters_Response'](results=[
                                                        T['rcl_interfaces/msg/SetParametersResult'](
                                                            successful=True, reason=''),
                                                        T['rcl_interfaces/msg/SetParametersResult'](
                                                            successful=False, reason='read-only')])),
    'rcl_interfaces__srv__SetParametersAtomically_Response': (
        'rcl_interfaces/msg/SetParametersAtomically_Response',
        T['rcl_interfaces/msg/SetParametersAtomically_Response'](
            result=T['rcl_interfaces/msg/SetParametersResult'](successful=False, reason='7 is out of range'))),
    'rcl_interfaces__srv__DescribeParameters_Response': ('rcl_interfaces/msg/DescribeParameters_Response',
                                                         T['rcl_interfaces/msg/DescribeParameters_Response'](
                                                             descriptors=descriptors())),
    'std_srvs__srv__Trigger_Response': ('std_srvs/msg/Trigger_Response',
                                        T['std_srvs/msg/Trigger_Response'](success=False, message='no board')),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--write', action='store_true', help='regenerate the fixtures')
    args = parser.parse_args()
    failures = 0
    for name, (typename, sample) in SAMPLES.items():
        data = bytes(ts.serialize_cdr(sample, typename))
        path = FIXTURES / f'{name}.cdr'
        if args.write:
            FIXTURES.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
            print(f'wrote {path.name:45} {len(data):4} bytes')
            continue
        stored = path.read_bytes() if path.exists() else None
        status = 'ok' if stored == data else 'DIFFERS'
        failures += stored != data
        print(f'{name:45} {len(data):4} bytes  {status}')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
