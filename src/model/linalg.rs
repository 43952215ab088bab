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
        // Slices, so that the inner product runs without bounds checks (the same products summed
        // in the same order as an indexed loop: the same result to the bit).
        let row = &l[i][..=i];
        let s: f64 = row[..i].iter().zip(&x[..i]).map(|(a, v)| a * v).sum();
        x[i] = (b[i] - s) / row[i];
    }
    x
}

/// Solves L·x = b for lower-triangular L and every right-hand side in `rhs` at once (each
/// overwritten by its solution). Each solution is computed with the same products summed in the
/// same order as [`solve_lower`] (from −0.0, as `Sum` does), so to the bit the same; the sums of
/// the different right-hand sides are independent and run interleaved, which the one-at-a-time
/// solve's single dependent chain of additions cannot (the fits whiten several basis columns and
/// the data with one factor: a tenth of the model stage's time before).
pub fn solve_lower_in_place(l: &[Vec<f64>], rhs: &mut [Vec<f64>]) {
    let mut groups = rhs.chunks_exact_mut(4);
    for group in &mut groups {
        solve_group::<4>(l, group);
    }
    for x in groups.into_remainder() {
        solve_group::<1>(l, std::slice::from_mut(x));
    }
}

/// [`solve_lower_in_place`] for exactly `C` right-hand sides, their running sums held in
/// registers.
fn solve_group<const C: usize>(l: &[Vec<f64>], cols: &mut [Vec<f64>]) {
    let n = cols.first().map_or(0, Vec::len);
    assert!(cols.len() == C && cols.iter().all(|x| x.len() == n));
    for i in 0..n {
        let row = &l[i][..=i];
        let mut sums = [-0.0; C];
        {
            let done: [&[f64]; C] = std::array::from_fn(|c| &cols[c][..i]);
            for (k, &a) in row[..i].iter().enumerate() {
                for c in 0..C {
                    sums[c] += a * done[c][k];
                }
            }
        }
        for (c, x) in cols.iter_mut().enumerate() {
            x[i] = (x[i] - sums[c]) / row[i];
        }
    }
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

    /// The interleaved solve gives each right-hand side exactly what the single solve gives.
    #[test]
    fn solving_many_at_once_is_solving_each_to_the_bit() {
        let n = 37;
        // An SPD matrix with irregular entries (a kernel of distances plus a ridge).
        let m: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|k| {
                        let d = (i as f64 - k as f64).abs();
                        (-d / 5.3).exp() + if i == k { 0.1 + 0.01 * i as f64 } else { 0.0 }
                    })
                    .collect()
            })
            .collect();
        let l = cholesky(&m).unwrap();
        let rhs: Vec<Vec<f64>> = (0..4)
            .map(|c| {
                (0..n)
                    .map(|i| ((i * 7 + c * 13) % 11) as f64 - 5.3)
                    .collect()
            })
            .collect();
        let mut many = rhs.clone();
        solve_lower_in_place(&l, &mut many);
        for (b, x) in rhs.iter().zip(&many) {
            let one = solve_lower(&l, b);
            assert!(one.iter().zip(x).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }

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
