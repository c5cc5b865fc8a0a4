//! RANSAC around a minimal pose solver, for correspondences with outliers.
