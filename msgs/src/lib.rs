//! ROS 2 message types of stereocal, their CDR encoding and `ros2msg` schemas, and
//! camera_info files.
