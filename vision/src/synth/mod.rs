//! Synthetic scenes with exact ground truth: a calibration target rendered through a
//! camera model with blur, noise and bad frames.
