"""Images read from a rosbag2 folder (such as the bag `stereocal synth` writes) with rosbags."""

import cv2
import numpy as np
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore


def messages(bag, topics):
    """(topic, message) of every message on `topics`, in bag order, with ROS 2 Humble's types."""
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(bag) as reader:
        connections = [c for c in reader.connections if c.topic in topics]
        for connection, _, raw in reader.messages(connections=connections):
            yield connection.topic, typestore.deserialize_cdr(raw, connection.msgtype)


def grey_images(bag, topics):
    """(topic, (sec, nanosec), grey image) of every mono8 or rgb8 image on `topics`, in bag order.

    An rgb8 image is turned grey with OpenCV's RGB2GRAY; row padding past `width` is dropped.
    """
    for topic, msg in messages(bag, topics):
        img = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)
        img = img[:, : msg.width * (3 if msg.encoding == "rgb8" else 1)]
        if msg.encoding == "rgb8":
            img = cv2.cvtColor(img.reshape(msg.height, msg.width, 3), cv2.COLOR_RGB2GRAY)
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec)
        yield topic, stamp, np.ascontiguousarray(img)
