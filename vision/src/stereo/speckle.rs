//! The speckle filter: small islands of disparity that differ from everything around
//! them are mismatches far more often than real objects, so they are invalidated
//! (OpenCV's `filterSpeckles`).

/// Reused buffers of the speckle filter.
#[derive(Default)]
pub(crate) struct SpeckleFilter {
    labels: Vec<u32>,
    small: Vec<bool>,
    stack: Vec<usize>,
}

impl SpeckleFilter {
    /// Invalidates (sets to NaN) every 4-connected region of valid disparities of at most
    /// `max_size` pixels, where neighbours of a region differ by at most `max_diff`.
    pub(crate) fn apply(
        &mut self,
        disparities: &mut [f32],
        width: usize,
        max_size: usize,
        max_diff: f32,
    ) {
        if max_size == 0 || width == 0 {
            return;
        }
        let height = disparities.len() / width;
        self.labels.clear();
        self.labels.resize(disparities.len(), 0);
        // Label 0 is "not yet visited"; region k has label k + 1.
        self.small.clear();
        for seed in 0..disparities.len() {
            if self.labels[seed] != 0 || disparities[seed].is_nan() {
                continue;
            }
            let label = self.small.len() as u32 + 1;
            self.labels[seed] = label;
            self.stack.clear();
            self.stack.push(seed);
            let mut size = 0usize;
            while let Some(p) = self.stack.pop() {
                size += 1;
                let (x, y) = (p % width, p / width);
                let value = disparities[p];
                let neighbours = [
                    (x > 0).then(|| p - 1),
                    (x + 1 < width).then(|| p + 1),
                    (y > 0).then(|| p - width),
                    (y + 1 < height).then(|| p + width),
                ];
                for q in neighbours.into_iter().flatten() {
                    let other = disparities[q];
                    if self.labels[q] == 0 && !other.is_nan() && (other - value).abs() <= max_diff {
                        self.labels[q] = label;
                        self.stack.push(q);
                    }
                }
            }
            self.small.push(size <= max_size);
        }
        for (disparity, &label) in disparities.iter_mut().zip(&self.labels) {
            if label != 0 && self.small[label as usize - 1] {
                *disparity = f32::NAN;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_islands_go_and_large_regions_stay() {
        let width = 10;
        let mut disparities = vec![20.0f32; width * 8];
        // A 2x2 island of 40 inside the plane of 20.
        for (x, y) in [(3, 3), (4, 3), (3, 4), (4, 4)] {
            disparities[y * width + x] = 40.0;
        }
        // A gentle ramp stays connected at max_diff 1.
        for x in 0..width {
            disparities[7 * width + x] = 20.0 + 0.5 * x as f32;
        }
        disparities[0] = f32::NAN;
        SpeckleFilter::default().apply(&mut disparities, width, 4, 1.0);
        let invalid: Vec<usize> = (0..disparities.len())
            .filter(|&i| disparities[i].is_nan())
            .collect();
        assert_eq!(invalid, vec![0, 33, 34, 43, 44]);
    }
}
