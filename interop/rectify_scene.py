"""The camera and images the rectify_node checks publish, and OpenCV's rectification of
them: a 320x240 plumb_bob camera with strong barrel distortion, tangential terms and a
rectifying rotation, and a checkerboard with gradients, on which nearest and bilinear
interpolation differ."""

import cv2
import numpy as np

WIDTH, HEIGHT = 320, 240
K = [260.0, 0.0, 161.5, 0.0, 262.0, 118.5, 0.0, 0.0, 1.0]
D = [-0.25, 0.08, 0.001, -0.0005, 0.0]
ANGLE = 0.03
R = [np.cos(ANGLE), 0.0, np.sin(ANGLE), 0.0, 1.0, 0.0, -np.sin(ANGLE), 0.0, np.cos(ANGLE)]
P = [240.0, 0.0, 158.0, 0.0, 0.0, 240.0, 121.0, 0.0, 0.0, 0.0, 1.0, 0.0]


def pixels(index, channels):
    """Image `index` of the scene, HEIGHT x WIDTH x `channels` uint8."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    checker = ((x // 20 + y // 20) % 2) * 160
    planes = [checker + (x * 3 + y * 5 + c * 40 + index * 11) % 90 for c in range(channels)]
    return np.stack(planes, axis=-1).astype(np.uint8).reshape(HEIGHT, WIDTH, channels)


def opencv_rectified(raw, interpolation=cv2.INTER_LINEAR):
    """OpenCV's initUndistortRectifyMap (fixed-point maps) + remap of `raw`, black
    outside the image, HEIGHT x WIDTH x channels."""
    maps = cv2.initUndistortRectifyMap(
        np.reshape(K, (3, 3)), np.array(D), np.reshape(R, (3, 3)), np.reshape(P, (3, 4)),
        (WIDTH, HEIGHT), cv2.CV_16SC2)
    out = cv2.remap(raw, *maps, interpolation, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return out.reshape(HEIGHT, WIDTH, -1)
