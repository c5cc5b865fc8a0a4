//! rosbag2 MCAP bags: streaming reader and writer.
