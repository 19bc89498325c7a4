//! A monotone, shape-preserving cubic spline through knots: the effective-area law that is
//! not a polynomial (issue #13 item 3).
//!
//! Piecewise cubic Hermite interpolation with the Fritsch–Butland slopes (Fritsch & Carlson
//! 1980, "Monotone piecewise cubic interpolation"; Fritsch & Butland 1984; the slopes of
//! scipy's `PchipInterpolator` and MATLAB's `pchip`): where the knot values rise (or fall) the
//! curve rises (or falls) between them, a local extremum of the knots is one of the curve, and
//! the curve never overshoots its knots. A quartic fitted to a force map does all three where
//! the map's effective area bends sharply (near the ends of a rolling lobe's stroke).
//!
//! Hand-written: the interpolant is 60 lines, and it must be evaluated inside every model's
//! right-hand side, integrated in closed form (the area-integral gas volume) and have its
//! knot values set one at a time by the estimator; the interpolation crates (`splines`,
//! `enterpolation`) have no shape-preserving slopes, and none integrates.

/// A monotone piecewise cubic through `(x_k, y_k)`, held at its end values outside the knots.
#[derive(Debug, Clone, PartialEq)]
pub struct MonotoneSpline {
    knots_x: Vec<f64>,
    values: Vec<f64>,
    /// The Fritsch–Butland slopes at the knots, recomputed whenever a value changes.
    slopes: Vec<f64>,
}

/// Why knots make no spline.
#[derive(Debug, Clone, PartialEq)]
pub enum SplineError {
    TooFewKnots(usize),
    LengthsDiffer { knots: usize, values: usize },
    NotIncreasing { index: usize },
    NotFinite { index: usize },
}

impl std::fmt::Display for SplineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooFewKnots(n) => write!(f, "{n} knots; a spline needs at least 2"),
            Self::LengthsDiffer { knots, values } => {
                write!(f, "{knots} knot positions but {values} values")
            }
            Self::NotIncreasing { index } => write!(
                f,
                "knot {index} is not above knot {}: the knots must increase strictly",
                index - 1
            ),
            Self::NotFinite { index } => write!(f, "knot {index} is not a finite number"),
        }
    }
}

impl MonotoneSpline {
    pub fn new(knots_x: Vec<f64>, values: Vec<f64>) -> Result<Self, SplineError> {
        if knots_x.len() != values.len() {
            return Err(SplineError::LengthsDiffer {
                knots: knots_x.len(),
                values: values.len(),
            });
        }
        if knots_x.len() < 2 {
            return Err(SplineError::TooFewKnots(knots_x.len()));
        }
        if let Some(index) =
            (0..knots_x.len()).find(|&k| !(knots_x[k].is_finite() && values[k].is_finite()))
        {
            return Err(SplineError::NotFinite { index });
        }
        if let Some(index) = (1..knots_x.len()).find(|&k| knots_x[k] <= knots_x[k - 1]) {
            return Err(SplineError::NotIncreasing { index });
        }
        let mut spline = Self {
            slopes: vec![0.0; knots_x.len()],
            knots_x,
            values,
        };
        spline.update_slopes();
        Ok(spline)
    }

    pub fn knots_x(&self) -> &[f64] {
        &self.knots_x
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Sets knot `index`'s value; `false` if there is no such knot.
    pub fn set_value(&mut self, index: usize, value: f64) -> bool {
        let Some(v) = self.values.get_mut(index) else {
            return false;
        };
        *v = value;
        self.update_slopes();
        true
    }

    fn update_slopes(&mut self) {
        let (x, y) = (&self.knots_x, &self.values);
        let n = x.len();
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let delta: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
        if n == 2 {
            self.slopes = vec![delta[0]; 2];
            return;
        }
        for k in 1..n - 1 {
            let (d0, d1) = (delta[k - 1], delta[k]);
            self.slopes[k] = if d0 * d1 <= 0.0 {
                0.0
            } else {
                // The weighted harmonic mean of the neighbouring secants (Fritsch–Butland).
                let w1 = 2.0 * h[k] + h[k - 1];
                let w2 = h[k] + 2.0 * h[k - 1];
                (w1 + w2) / (w1 / d0 + w2 / d1)
            };
        }
        self.slopes[0] = end_slope(h[0], h[1], delta[0], delta[1]);
        self.slopes[n - 1] = end_slope(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
    }

    /// The interval `[x_k, x_{k+1}]` holding `x` (inside the knots).
    fn interval(&self, x: f64) -> usize {
        self.knots_x
            .partition_point(|&k| k <= x)
            .saturating_sub(1)
            .min(self.knots_x.len() - 2)
    }

    /// The value at `x`; the end value outside the knots.
    pub fn value(&self, x: f64) -> f64 {
        let n = self.knots_x.len();
        if x <= self.knots_x[0] {
            return self.values[0];
        }
        if x >= self.knots_x[n - 1] {
            return self.values[n - 1];
        }
        let k = self.interval(x);
        let h = self.knots_x[k + 1] - self.knots_x[k];
        let t = (x - self.knots_x[k]) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.values[k]
            + (t3 - 2.0 * t2 + t) * h * self.slopes[k]
            + (-2.0 * t3 + 3.0 * t2) * self.values[k + 1]
            + (t3 - t2) * h * self.slopes[k + 1]
    }

    /// `d value / dx`; zero outside the knots.
    pub fn slope(&self, x: f64) -> f64 {
        let n = self.knots_x.len();
        if x <= self.knots_x[0] || x >= self.knots_x[n - 1] {
            return 0.0;
        }
        let k = self.interval(x);
        let h = self.knots_x[k + 1] - self.knots_x[k];
        let t = (x - self.knots_x[k]) / h;
        let t2 = t * t;
        ((6.0 * t2 - 6.0 * t) * (self.values[k] - self.values[k + 1])) / h
            + (3.0 * t2 - 4.0 * t + 1.0) * self.slopes[k]
            + (3.0 * t2 - 2.0 * t) * self.slopes[k + 1]
    }

    /// `∫_0^x value`, in closed form (the value held at its ends outside the knots).
    pub fn integral_from_zero(&self, x: f64) -> f64 {
        self.antiderivative(x) - self.antiderivative(0.0)
    }

    /// An antiderivative: zero at the first knot.
    fn antiderivative(&self, x: f64) -> f64 {
        let n = self.knots_x.len();
        let x0 = self.knots_x[0];
        if x <= x0 {
            return self.values[0] * (x - x0);
        }
        let mut sum = 0.0;
        for k in 0..n - 1 {
            let (a, b) = (self.knots_x[k], self.knots_x[k + 1]);
            if x <= a {
                return sum;
            }
            let h = b - a;
            let t = ((x - a) / h).min(1.0);
            let (t2, t3, t4) = (t * t, t * t * t, t * t * t * t);
            sum += h
                * ((t4 / 2.0 - t3 + t) * self.values[k]
                    + (t4 / 4.0 - 2.0 * t3 / 3.0 + t2 / 2.0) * h * self.slopes[k]
                    + (-t4 / 2.0 + t3) * self.values[k + 1]
                    + (t4 / 4.0 - t3 / 3.0) * h * self.slopes[k + 1]);
        }
        sum + self.values[n - 1] * (x - self.knots_x[n - 1]).max(0.0)
    }
}

/// The one-sided three-point slope at an end, kept shape-preserving (scipy's `_edge_case`):
/// `h0`, `delta0` the end interval's width and secant, `h1`, `delta1` its neighbour's.
fn end_slope(h0: f64, h1: f64, delta0: f64, delta1: f64) -> f64 {
    let d = ((2.0 * h0 + h1) * delta0 - h0 * delta1) / (h0 + h1);
    if d.signum() != delta0.signum() || delta0 == 0.0 {
        0.0
    } else if delta0.signum() != delta1.signum() && d.abs() > 3.0 * delta0.abs() {
        3.0 * delta0
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spline(x: &[f64], y: &[f64]) -> MonotoneSpline {
        MonotoneSpline::new(x.to_vec(), y.to_vec()).unwrap()
    }

    #[test]
    fn reproduces_a_straight_line_and_its_integral() {
        // 10 x - 1 at each knot.
        let s = spline(&[0.2, 0.25, 0.32, 0.4], &[1.0, 1.5, 2.2, 3.0]);
        for &x in &[0.2, 0.21, 0.25, 0.27, 0.33, 0.399, 0.4] {
            assert!((s.value(x) - (10.0 * x - 1.0)).abs() < 1e-12, "{x}");
        }
        for &x in &[0.21, 0.25, 0.27, 0.33, 0.399] {
            assert!((s.slope(x) - 10.0).abs() < 1e-9, "{x}");
        }
        // Held outside: no slope there.
        assert_eq!(s.slope(0.1), 0.0);
        assert_eq!(s.value(0.1), 1.0);
        // Held at 1.0 below 0.2: ∫0^0.2 = 0.2; then ∫0.2^0.3 (10x − 1) dx = 0.15.
        assert!((s.integral_from_zero(0.3) - 0.35).abs() < 1e-12);
        // Held at 3.0 above 0.4: ∫0.2^0.4 = 0.4, and 0.1 × 3 beyond.
        assert!((s.integral_from_zero(0.5) - 0.9).abs() < 1e-12);
    }

    #[test]
    fn monotone_knots_give_a_monotone_curve_without_overshoot() {
        // A step-like rise: a natural cubic spline overshoots both shoulders here.
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let y = [0.0, 0.0, 0.1, 1.9, 2.0, 2.0];
        let s = spline(&x, &y);
        let mut last = f64::NEG_INFINITY;
        for i in 0..=500 {
            let v = s.value(5.0 * f64::from(i) / 500.0);
            assert!(v >= last - 1e-15, "falls at {i}");
            assert!((0.0..=2.0).contains(&v), "overshoots: {v}");
            last = v;
        }
        // A peak among the knots is the curve's peak.
        let p = spline(&[0.0, 1.0, 2.0], &[0.0, 1.0, 0.0]);
        assert!(p.slope(1.0 - 1e-12).abs() < 1e-9);
        assert!((0..=200).all(|i| p.value(2.0 * f64::from(i) / 200.0) <= 1.0 + 1e-15));
    }

    #[test]
    fn slope_and_integral_agree_with_the_value_numerically() {
        let s = spline(
            &[0.2, 0.24, 0.3, 0.33, 0.4, 0.45],
            &[0.08, 0.1, 0.11, 0.115, 0.12, 0.2],
        );
        for i in 1..100 {
            let x = 0.15 + 0.35 * f64::from(i) / 100.0;
            let e = 1e-7;
            let fd = (s.value(x + e) - s.value(x - e)) / (2.0 * e);
            assert!(
                (fd - s.slope(x)).abs() < 1e-5,
                "slope at {x}: {fd} {}",
                s.slope(x)
            );
            let fd = (s.integral_from_zero(x + e) - s.integral_from_zero(x - e)) / (2.0 * e);
            assert!((fd - s.value(x)).abs() < 1e-8, "integral at {x}");
        }
        // Simpson's rule over the knots' span.
        let m = 2000;
        let (a, b) = (0.2, 0.45);
        let w = (b - a) / f64::from(m);
        let simpson: f64 = (0..=m)
            .map(|i| {
                let c = if i == 0 || i == m {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                c * s.value(a + w * f64::from(i))
            })
            .sum::<f64>()
            * w
            / 3.0;
        let exact = s.integral_from_zero(b) - s.integral_from_zero(a);
        assert!((simpson - exact).abs() < 1e-10, "{simpson} {exact}");
    }

    #[test]
    fn setting_a_value_moves_the_slopes_with_it() {
        let mut s = spline(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 2.0, 3.0]);
        assert!(s.set_value(2, 1.0));
        // Knot 1 is now a plateau's start: values 0, 1, 1, 3 give it slope zero.
        assert!(s.slope(1.0 + 1e-12).abs() < 1e-9);
        assert!(!s.set_value(4, 1.0));
        assert_eq!(s.values(), &[0.0, 1.0, 1.0, 3.0]);
    }

    #[test]
    fn bad_knots_are_refused() {
        let e = |x: &[f64], y: &[f64]| MonotoneSpline::new(x.to_vec(), y.to_vec()).unwrap_err();
        assert_eq!(e(&[0.0], &[1.0]), SplineError::TooFewKnots(1));
        assert_eq!(
            e(&[0.0, 1.0], &[1.0]),
            SplineError::LengthsDiffer {
                knots: 2,
                values: 1
            }
        );
        assert_eq!(
            e(&[0.0, 1.0, 1.0], &[1.0; 3]),
            SplineError::NotIncreasing { index: 2 }
        );
        assert_eq!(
            e(&[0.0, f64::NAN], &[1.0; 2]),
            SplineError::NotFinite { index: 1 }
        );
    }
}
