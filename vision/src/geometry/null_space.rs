//! Null spaces of the small linear systems of the minimal solvers (the 7-point and
//! 5-point epipolar constraints), by Gauss-Jordan elimination with full pivoting:
//! faster than an SVD and as accurate on these well-scaled systems.

/// A basis of the null space of the `R x 9` matrix with the given rows, `9 - R` vectors
/// (not orthonormal); `None` when the rows are not linearly independent.
pub(crate) fn null_space<const R: usize>(rows: &[[f64; 9]; R]) -> Option<Vec<[f64; 9]>> {
    let mut m = *rows;
    let mut columns: [usize; 9] = [0, 1, 2, 3, 4, 5, 6, 7, 8];
    let scale = m
        .iter()
        .flat_map(|row| row.iter())
        .fold(0.0_f64, |s, v| s.max(v.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for r in 0..R {
        let (mut pivot_row, mut pivot_column, mut largest) = (r, r, 0.0);
        for (i, row) in m.iter().enumerate().skip(r) {
            for (j, value) in row.iter().enumerate().skip(r) {
                if value.abs() > largest {
                    (pivot_row, pivot_column, largest) = (i, j, value.abs());
                }
            }
        }
        if largest <= 1e-12 * scale {
            return None;
        }
        m.swap(r, pivot_row);
        for row in m.iter_mut() {
            row.swap(r, pivot_column);
        }
        columns.swap(r, pivot_column);
        let pivot = m[r][r];
        for value in m[r].iter_mut() {
            *value /= pivot;
        }
        let pivot_values = m[r];
        for (i, row) in m.iter_mut().enumerate() {
            if i != r {
                let factor = row[r];
                if factor != 0.0 {
                    for (value, p) in row.iter_mut().zip(&pivot_values) {
                        *value -= factor * p;
                    }
                }
            }
        }
    }
    // m is now [I | N] in the permuted columns: each free column gives one null vector.
    Some(
        (R..9)
            .map(|free| {
                let mut v = [0.0; 9];
                v[columns[free]] = 1.0;
                for (i, row) in m.iter().enumerate() {
                    v[columns[i]] = -row[free];
                }
                v
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_vectors_annihilate_the_rows() {
        let rows = [
            [1.0, 2.0, 0.5, -1.0, 3.0, 0.0, 2.0, 1.0, -0.5],
            [0.0, 1.0, 4.0, 2.0, -1.0, 1.0, 0.0, 3.0, 1.0],
            [2.0, -1.0, 1.0, 0.0, 0.5, 2.0, 1.0, -1.0, 0.0],
            [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0],
            [-3.0, 0.0, 2.0, 1.0, 0.0, -2.0, 4.0, 0.5, 1.0],
        ];
        let basis = null_space(&rows).unwrap();
        assert_eq!(basis.len(), 4);
        for v in &basis {
            for row in &rows {
                let dot: f64 = row.iter().zip(v).map(|(a, b)| a * b).sum();
                assert!(dot.abs() < 1e-12, "{dot}");
            }
        }
        let mut dependent = rows;
        dependent[4] = rows[0];
        assert!(null_space(&dependent).is_none());
    }
}
