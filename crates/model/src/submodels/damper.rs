//! Damper force: a piecewise-affine look-up table (thesis 3.1.2, Fig 3.5; no physics).

use airsus_data::DamperTable;

/// Damper force against extension velocity, piecewise affine through the table points, with
/// rounded corners (see [`Damper::force_n`]).
///
/// Sign convention (SPEC §5): positive velocity is extension (rebound); the force is the
/// resisting force, positive in rebound, so the power `F·v` it absorbs is non-negative for a
/// passive table. Beyond the table's ends the force is **extrapolated linearly** with the slope
/// of the first/last segment (a real damper keeps resisting harder; clamping would make it
/// force-free at high speed). The slopes are precomputed so [`Damper::force_n`] does no
/// allocation and, outside the rounded corners, no division.
#[derive(Debug, Clone, PartialEq)]
pub struct Damper {
    velocity_m_s: Vec<f64>,
    force_n: Vec<f64>,
    slope_n_s_per_m: Vec<f64>,
}

impl Damper {
    /// Builds the table, its forces times the table's scale. `airsus-data` guarantees at least
    /// two points with strictly increasing velocities; a table violating that (built in code)
    /// degrades to zero force rather than panicking.
    pub fn new(table: &DamperTable) -> Self {
        let n = table.velocity_m_s.len().min(table.force_n.len());
        let velocity_m_s = table.velocity_m_s[..n].to_vec();
        let force_n: Vec<f64> = (0..n).map(|i| table.corrected_force_n(i)).collect();
        let slope_n_s_per_m = (0..n.saturating_sub(1))
            .map(|i| {
                let dv = velocity_m_s[i + 1] - velocity_m_s[i];
                if dv > 0.0 {
                    (force_n[i + 1] - force_n[i]) / dv
                } else {
                    0.0
                }
            })
            .collect();
        Self {
            velocity_m_s,
            force_n,
            slope_n_s_per_m,
        }
    }

    /// A damper that produces no force (for energy-conservation tests and "damper off").
    pub fn zero() -> Self {
        Self::new(&DamperTable::new(vec![-1.0, 1.0], vec![0.0, 0.0]))
    }

    /// Force, N, at extension velocity `velocity_m_s`, m/s.
    ///
    /// Piecewise affine through the table, except within [`CORNER_HALF_WIDTH_M_S`] of an
    /// interior point, where a monotone cubic (PCHIP: Hermite pieces through the point, the
    /// slope there the harmonic mean of the two segments') joins the segments with a
    /// continuous slope. The force still passes through every table point. Why: the table's
    /// corner at zero velocity, where a truck at rest sits, made the implicit solvers' Newton
    /// iteration cycle between the two slopes ("too many Newton failures" with a light
    /// lever: 178 of 1180 grey-box simulations of Model 2 failed on data-set 3); a real
    /// damper's bleed orifice has no corner either.
    pub fn force_n(&self, velocity_m_s: f64) -> f64 {
        let v = &self.velocity_m_s;
        if self.slope_n_s_per_m.is_empty() {
            return 0.0;
        }
        // Segment index: the last point not above v, clamped to a valid segment so the end
        // segments extend linearly. Tables are short (≈7 points): a linear scan beats bisection.
        let last = self.slope_n_s_per_m.len() - 1;
        let mut i = 0;
        while i < last && velocity_m_s >= v[i + 1] {
            i += 1;
        }
        // The interior point nearest to the velocity, if it is within its corner.
        let corner = [i, i + 1]
            .into_iter()
            .filter(|&k| k >= 1 && k <= last)
            .find(|&k| (velocity_m_s - v[k]).abs() < self.corner_half_width(k));
        match corner {
            Some(k) => self.corner_force(k, velocity_m_s),
            None => self.force_n[i] + self.slope_n_s_per_m[i] * (velocity_m_s - v[i]),
        }
    }

    /// Half-width of the rounded corner at interior point `k`: the constant, or a quarter of
    /// the shorter neighbouring segment.
    fn corner_half_width(&self, k: usize) -> f64 {
        let v = &self.velocity_m_s;
        CORNER_HALF_WIDTH_M_S
            .min(0.25 * (v[k] - v[k - 1]))
            .min(0.25 * (v[k + 1] - v[k]))
    }

    /// The monotone cubic across the corner at interior point `k` (see [`Self::force_n`]).
    fn corner_force(&self, k: usize, velocity_m_s: f64) -> f64 {
        let (left, right) = (self.slope_n_s_per_m[k - 1], self.slope_n_s_per_m[k]);
        let middle = if left * right > 0.0 {
            2.0 * left * right / (left + right)
        } else {
            0.0
        };
        let d = self.corner_half_width(k);
        let (vk, fk) = (self.velocity_m_s[k], self.force_n[k]);
        // Hermite piece on [a, a + d] from (f_a, m_a) to (f_b, m_b).
        let hermite = |a: f64, f_a: f64, m_a: f64, f_b: f64, m_b: f64| {
            let t = (velocity_m_s - a) / d;
            let (t2, t3) = (t * t, t * t * t);
            (2.0 * t3 - 3.0 * t2 + 1.0) * f_a
                + (t3 - 2.0 * t2 + t) * d * m_a
                + (-2.0 * t3 + 3.0 * t2) * f_b
                + (t3 - t2) * d * m_b
        };
        if velocity_m_s < vk {
            hermite(vk - d, fk - left * d, left, fk, middle)
        } else {
            hermite(vk, fk, middle, fk + right * d, right)
        }
    }
}

/// Half-width of the rounded corners of the damper table, m/s (see [`Damper::force_n`]): at
/// most 5 mm/s. The force leaves the segments by at most `(4/27) d |s_mid − s|` (`s` a
/// segment's slope, `s_mid` the corner's): about 7 N at the reference table's zero-velocity
/// corner (15 and 30 kN s/m).
pub const CORNER_HALF_WIDTH_M_S: f64 = 0.005;

#[cfg(test)]
mod tests {
    use super::*;

    fn reference() -> Damper {
        Damper::new(&DamperTable::new(
            vec![-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0],
            vec![-6000.0, -4000.0, -1500.0, 0.0, 3000.0, 9000.0, 13000.0],
        ))
    }

    #[test]
    fn interpolates_between_points() {
        let d = reference();
        assert_eq!(d.force_n(0.0), 0.0);
        assert!((d.force_n(0.1) - 3000.0).abs() < 1e-9);
        // halfway between 0.1 and 0.5: (3000 + 9000) / 2
        assert!((d.force_n(0.3) - 6000.0).abs() < 1e-9);
        // between -0.5 and -0.1: slope 2500/0.4 = 6250 N s/m; at -0.3: -4000 + 6250*0.2 = -2750
        assert!((d.force_n(-0.3) + 2750.0).abs() < 1e-9);
        assert!((d.force_n(-1.0) + 6000.0).abs() < 1e-9);
    }

    #[test]
    fn corners_are_rounded_with_a_continuous_slope_through_the_points() {
        let d = reference();
        let slope = |v: f64| (d.force_n(v + 1e-7) - d.force_n(v - 1e-7)) / 2e-7;
        // Through the table point; the slope there the harmonic mean of 15000 and 30000.
        assert_eq!(d.force_n(0.0), 0.0);
        assert!((slope(0.0) - 20_000.0).abs() < 1.0, "{}", slope(0.0));
        // On the segments just outside the corner, and their slopes reached continuously.
        let w = CORNER_HALF_WIDTH_M_S;
        assert!((d.force_n(w) - 30_000.0 * w).abs() < 1e-9);
        assert!((d.force_n(-w) + 15_000.0 * w).abs() < 1e-9);
        assert!((slope(w - 1e-6) - 30_000.0).abs() < 50.0);
        assert!((slope(-w + 1e-6) - 15_000.0).abs() < 50.0);
        // Monotone and passive across the corner, and within a few newtons of the segments.
        let mut last = f64::NEG_INFINITY;
        for k in -100..=100 {
            let v = f64::from(k) * w / 100.0;
            let f = d.force_n(v);
            assert!(f > last && f * v >= 0.0, "v {v}: {f}");
            let affine = if v < 0.0 { 15_000.0 * v } else { 30_000.0 * v };
            assert!((f - affine).abs() < 20.0, "v {v}: {f} vs {affine}");
            last = f;
        }
    }

    #[test]
    fn extrapolates_linearly_beyond_the_ends() {
        let d = reference();
        // last segment slope (13000-9000)/0.5 = 8000 N s/m: at 1.5 m/s 13000 + 4000
        assert!((d.force_n(1.5) - 17_000.0).abs() < 1e-9);
        // first segment slope (-4000+6000)/0.5 = 4000 N s/m: at -2 m/s -6000 - 4000
        assert!((d.force_n(-2.0) + 10_000.0).abs() < 1e-9);
    }

    #[test]
    fn the_scale_multiplies_every_force_corners_and_ends_included() {
        let d = reference();
        let mut table = DamperTable::new(
            vec![-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0],
            vec![-6000.0, -4000.0, -1500.0, 0.0, 3000.0, 9000.0, 13000.0],
        );
        table.scale = 1.25;
        let scaled = Damper::new(&table);
        for v in [-2.0, -0.3, -0.1, -1e-3, 0.0, 2e-3, 0.1, 0.3, 1.5] {
            let (f, g) = (d.force_n(v), scaled.force_n(v));
            assert!(
                (g - 1.25 * f).abs() < 1e-9 * f.abs().max(1.0),
                "v {v}: {g} vs {f}"
            );
        }
    }

    #[test]
    fn zero_table_and_degenerate_table_give_no_force() {
        assert_eq!(Damper::zero().force_n(3.0), 0.0);
        let d = Damper::new(&DamperTable::new(vec![0.0], vec![1.0]));
        assert_eq!(d.force_n(1.0), 0.0);
    }
}
