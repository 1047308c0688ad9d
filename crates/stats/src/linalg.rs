//! The small dense linear algebra of the fits: solving a few normal equations and inverting a small covariance,
//! by elimination with partial pivoting (systems of at most a dozen unknowns, where this is exact enough and
//! nothing is gained from a library).

/// Solve `a x = b` by Gaussian elimination with partial pivoting; `None` when a pivot is not larger than
/// `min_pivot` in magnitude (singular, or too close to it to trust).
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>, min_pivot: f64) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let piv = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if !(a[piv][c].abs() > min_pivot) {
            return None;
        }
        a.swap(c, piv);
        b.swap(c, piv);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            if f != 0.0 {
                for k in c..n {
                    a[r][k] -= f * a[c][k];
                }
                b[r] -= f * b[c];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// The inverse of a small square matrix by Gauss-Jordan elimination with partial pivoting; `None` when a pivot
/// is smaller than `min_pivot` in magnitude.
pub fn invert(a: &[Vec<f64>], min_pivot: f64) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))?;
        if m[piv][col].abs() < min_pivot {
            return None;
        }
        m.swap(col, piv);
        let d = m[col][col];
        for v in &mut m[col] {
            *v /= d;
        }
        for r in 0..n {
            if r != col {
                let f = m[r][col];
                if f != 0.0 {
                    for c in 0..2 * n {
                        m[r][c] -= f * m[col][c];
                    }
                }
            }
        }
    }
    Some(m.into_iter().map(|r| r[n..].to_vec()).collect())
}

/// The lower Cholesky factor `L` of a symmetric positive definite matrix (`a = L L^T`); `None` when a pivot is
/// not positive (the matrix is not positive definite to rounding).
pub fn cholesky(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut l: Vec<Vec<f64>> = Vec::with_capacity(n);
    for (i, a_i) in a.iter().enumerate() {
        // Row i from the rows above it: the dot products run over slices, in the same order as the textbook's
        // index loop (so the same rounding), without its bounds checks.
        let mut row = vec![0.0; n];
        for j in 0..i {
            let l_j = &l[j][..j];
            let s = a_i[j] - row[..j].iter().zip(l_j).map(|(p, q)| p * q).sum::<f64>();
            row[j] = s / l[j][j];
        }
        let s = a_i[i] - row[..i].iter().map(|p| p * p).sum::<f64>();
        if !(s > 0.0) {
            return None;
        }
        row[i] = s.sqrt();
        l.push(row);
    }
    Some(l)
}

/// `L^-1 b` for a lower triangular `L` (forward substitution): with `L` the Cholesky factor of a covariance,
/// this whitens `b`.
pub fn forward_solve(l: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; b.len()];
    for (i, (l_i, b_i)) in l.iter().zip(b).enumerate() {
        let s: f64 = l_i[..i].iter().zip(&x[..i]).map(|(p, q)| p * q).sum();
        x[i] = (b_i - s) / l_i[i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_system_is_solved_and_inverted() {
        let a = vec![vec![4.0, 1.0, 2.0], vec![1.0, 5.0, 3.0], vec![2.0, 3.0, 6.0]];
        let x_true = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a.iter().map(|r| r.iter().zip(&x_true).map(|(p, q)| p * q).sum()).collect();
        let x = solve(a.clone(), b, 0.0).unwrap();
        for (u, v) in x.iter().zip(&x_true) {
            assert!((u - v).abs() < 1e-12);
        }
        let inv = invert(&a, 1e-12).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
        assert!(solve(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0], 1e-13).is_none());
        assert!(invert(&[vec![1.0, 2.0], vec![2.0, 4.0]], 1e-12).is_none());
    }

    #[test]
    fn cholesky_factors_and_whitens() {
        let a = vec![vec![4.0, 2.0, 0.4], vec![2.0, 5.0, 1.0], vec![0.4, 1.0, 3.0]];
        let l = cholesky(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| l[i][k] * l[j][k]).sum();
                assert!((p - a[i][j]).abs() < 1e-12);
            }
        }
        // b^T a^-1 b = |L^-1 b|^2.
        let b = [1.0, -1.0, 2.0];
        let w = forward_solve(&l, &b);
        let inv = invert(&a, 1e-12).unwrap();
        let q: f64 = (0..3).map(|i| (0..3).map(|j| b[i] * inv[i][j] * b[j]).sum::<f64>()).sum();
        assert!((w.iter().map(|v| v * v).sum::<f64>() - q).abs() < 1e-12);
        assert!(cholesky(&[vec![1.0, 2.0], vec![2.0, 1.0]]).is_none());
    }
}
