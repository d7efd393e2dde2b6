//! numpy's arithmetic, step for step, where Ultralytics and pycocotools rely on it: the last bit of
//! `linspace`, `interp` and pairwise summation shows in the metrics, and the tests pin them to 1e-6.

/// `np.linspace(start, stop, num)` (endpoint included), computed as numpy does: `i * step + start`, with
/// the last value set to `stop`.
pub(super) fn np_linspace(start: f64, stop: f64, num: usize) -> Vec<f64> {
    let step = (stop - start) / (num - 1) as f64;
    let mut y: Vec<f64> = (0..num).map(|i| i as f64 * step + start).collect();
    y[num - 1] = stop;
    y
}

/// `np.interp(x, xp, fp, left, right)` for one `x`, with numpy's choice of segment (the last `j` with
/// `xp[j] <= x`, so repeated `xp` take the value of the last repeat) and its formula.
pub(super) fn np_interp(x: f64, xp: &[f64], fp: &[f64], left: f64, right: f64) -> f64 {
    let n = xp.len();
    if n == 1 {
        return if x < xp[0] {
            left
        } else if x > xp[0] {
            right
        } else {
            fp[0]
        };
    }
    if x > xp[n - 1] {
        return right;
    }
    if x < xp[0] {
        return left;
    }
    let j = xp.partition_point(|&v| v <= x) - 1;
    if j == n - 1 || xp[j] == x {
        return fp[j];
    }
    let slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
    let mut r = slope * (x - xp[j]) + fp[j];
    if r.is_nan() {
        r = slope * (x - xp[j + 1]) + fp[j + 1];
        if r.is_nan() && fp[j] == fp[j + 1] {
            r = fp[j];
        }
    }
    r
}

/// numpy's pairwise summation (`np.add.reduce` on a contiguous float64 array).
fn np_sum(a: &[f64]) -> f64 {
    fn pairwise(a: &[f64]) -> f64 {
        let n = a.len();
        if n < 8 {
            let mut res = 0.0;
            for &v in a {
                res += v;
            }
            res
        } else if n <= 128 {
            let mut r = [0.0; 8];
            r.copy_from_slice(&a[..8]);
            let mut i = 8;
            while i < n - n % 8 {
                for (k, rk) in r.iter_mut().enumerate() {
                    *rk += a[i + k];
                }
                i += 8;
            }
            let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
            while i < n {
                res += a[i];
                i += 1;
            }
            res
        } else {
            let mut n2 = n / 2;
            n2 -= n2 % 8;
            pairwise(&a[..n2]) + pairwise(&a[n2..])
        }
    }
    0.0 + pairwise(a)
}

pub(super) fn np_mean(a: &[f64]) -> f64 {
    np_sum(a) / a.len() as f64
}

/// `np.trapezoid(y, x)` for 1-D arrays.
pub(super) fn np_trapezoid(y: &[f64], x: &[f64]) -> f64 {
    let terms: Vec<f64> = (0..y.len() - 1)
        .map(|i| (x[i + 1] - x[i]) * (y[i + 1] + y[i]) / 2.0)
        .collect();
    np_sum(&terms)
}

/// Row mean of equally long rows (`a.mean(0)`); empty when there are no rows.
pub(super) fn mean_rows(rows: &[Vec<f64>]) -> Vec<f64> {
    let Some(first) = rows.first() else {
        return Vec::new();
    };
    let mut out = vec![0.0; first.len()];
    for row in rows {
        for (o, v) in out.iter_mut().zip(row) {
            *o += v;
        }
    }
    let n = rows.len() as f64;
    out.iter_mut().for_each(|o| *o /= n);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linspace_matches_numpy() {
        // np.linspace(.5, 0.95, 10) of pycocotools: 0.8999999999999999 at index 8, 0.75 exact
        let coco_thr = np_linspace(0.5, 0.95, 10);
        assert_eq!(coco_thr[8], 0.8999999999999999);
        assert_eq!(coco_thr[5], 0.75);
        assert_eq!(np_linspace(0.0, 1.0, 101)[7], 0.07);
    }

    #[test]
    fn numpy_interp_rules() {
        let xp = [0.0, 0.5, 0.5, 1.0];
        let fp = [1.0, 1.0, 0.0, 0.0];
        assert_eq!(np_interp(0.5, &xp, &fp, 9.0, 9.0), 0.0); // last of the repeats
        assert_eq!(np_interp(0.25, &xp, &fp, 9.0, 9.0), 1.0);
        assert_eq!(np_interp(-0.1, &xp, &fp, 7.0, 9.0), 7.0);
        assert_eq!(np_interp(1.1, &xp, &fp, 7.0, 9.0), 9.0);
        assert_eq!(np_interp(2.0, &[2.0], &[3.0], 0.0, 1.0), 3.0);
        let v: Vec<f64> = (0..300).map(|i| (i as f64).sin()).collect();
        assert!((np_sum(&v) - v.iter().sum::<f64>()).abs() < 1e-9);
    }
}
