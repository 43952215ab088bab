//! The little dense linear algebra the fits need: at most five unknowns and a few hundred points,
//! so plain loops over column vectors are fast and easy to check. Householder QR for least
//! squares (better conditioned than normal equations: the basis columns of neighbouring terms are
//! far from orthogonal), Cholesky for covariance matrices.

/// Least-squares solution of min ‖Σ_j x_j·cols[j] − b‖ by Householder QR. Returns `None` when the
/// columns are (numerically) dependent.
pub fn lstsq(cols: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let p = cols.len();
    let n = b.len();
    if p == 0 {
        return Some(Vec::new());
    }
    if p > n || cols.iter().any(|c| c.len() != n) {
        return None;
    }
    let mut a: Vec<Vec<f64>> = cols.to_vec();
    let mut y = b.to_vec();
    let scale = a
        .iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    for k in 0..p {
        let norm = a[k][k..].iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= 1e-13 * scale {
            return None;
        }
        let alpha = if a[k][k] > 0.0 { -norm } else { norm };
        // v = a_k[k..] − α e_1, reflector H = I − 2vvᵀ/vᵀv.
        let mut v = a[k][k..].to_vec();
        v[0] -= alpha;
        let vv: f64 = v.iter().map(|x| x * x).sum();
        if vv == 0.0 {
            continue;
        }
        for col in a.iter_mut().skip(k) {
            let dot: f64 = v.iter().zip(&col[k..]).map(|(a, b)| a * b).sum();
            let f = 2.0 * dot / vv;
            for (c, vi) in col[k..].iter_mut().zip(&v) {
                *c -= f * vi;
            }
        }
        let dot: f64 = v.iter().zip(&y[k..]).map(|(a, b)| a * b).sum();
        let f = 2.0 * dot / vv;
        for (c, vi) in y[k..].iter_mut().zip(&v) {
            *c -= f * vi;
        }
    }
    // Back substitution on the upper triangle R (a[j][i], i ≤ j).
    let mut x = vec![0.0; p];
    for i in (0..p).rev() {
        let s: f64 = (i + 1..p).map(|j| a[j][i] * x[j]).sum();
        x[i] = (y[i] - s) / a[i][i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Lower Cholesky factor L (row-major, L·Lᵀ = m) of a symmetric positive-definite matrix given as
/// rows; `None` if it is not positive definite.
pub fn cholesky(m: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = m.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = m[i][i] - s;
                if d.is_nan() || d <= 0.0 {
                    return None;
                }
                l[i][i] = d.sqrt();
            } else {
                l[i][j] = (m[i][j] - s) / l[j][j];
            }
        }
    }
    Some(l)
}

/// Solves L·x = b for lower-triangular L.
pub fn solve_lower(l: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; b.len()];
    for i in 0..b.len() {
        let s: f64 = (0..i).map(|k| l[i][k] * x[k]).sum();
        x[i] = (b[i] - s) / l[i][i];
    }
    x
}

/// Inverse of a symmetric positive-definite matrix (rows), via Cholesky.
pub fn inverse_spd(m: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = m.len();
    let l = cholesky(m)?;
    let mut inv = vec![vec![0.0; n]; n];
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        // Solve L y = e, then Lᵀ x = y.
        let y = solve_lower(&l, &e);
        let mut x = vec![0.0; n];
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|k| l[k][i] * x[k]).sum();
            x[i] = (y[i] - s) / l[i][i];
        }
        for i in 0..n {
            inv[i][j] = x[i];
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lstsq_fits_an_exact_polynomial_and_flags_dependence() {
        let t: Vec<f64> = (0..10).map(f64::from).collect();
        let cols = vec![
            vec![1.0; 10],
            t.clone(),
            t.iter().map(|x| x * x).collect::<Vec<_>>(),
        ];
        let b: Vec<f64> = t.iter().map(|x| 2.0 - 3.0 * x + 0.5 * x * x).collect();
        let x = lstsq(&cols, &b).unwrap();
        for (got, want) in x.iter().zip([2.0, -3.0, 0.5]) {
            assert!((got - want).abs() < 1e-12, "{x:?}");
        }
        let dependent = vec![t.clone(), t.iter().map(|x| 2.0 * x).collect()];
        assert!(lstsq(&dependent, &b).is_none());
    }

    #[test]
    fn lstsq_is_the_projection_for_an_inconsistent_system() {
        // Mean of b is the LS constant.
        let x = lstsq(&[vec![1.0; 4]], &[1.0, 2.0, 3.0, 6.0]).unwrap();
        assert!((x[0] - 3.0).abs() < 1e-15);
    }

    #[test]
    fn cholesky_and_inverse() {
        let m = vec![
            vec![4.0, 2.0, 0.4],
            vec![2.0, 3.0, 0.5],
            vec![0.4, 0.5, 1.0],
        ];
        let inv = inverse_spd(&m).unwrap();
        for (i, row) in m.iter().enumerate() {
            for j in 0..3 {
                let p: f64 = row.iter().zip(&inv).map(|(a, r)| a * r[j]).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-14);
            }
        }
        assert!(cholesky(&[vec![1.0, 2.0], vec![2.0, 1.0]]).is_none());
    }
}
