//! Stereo rectification (Bouguet), undistort/rectify maps and remap.
