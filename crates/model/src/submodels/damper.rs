//! Damper force: a piecewise-affine look-up table (thesis 3.1.2, Fig 3.5; no physics).

use airsus_data::DamperTable;

/// Damper force against extension velocity, piecewise affine through the table points.
///
/// Sign convention (SPEC §5): positive velocity is extension (rebound); the force is the
/// resisting force, positive in rebound, so the power `F·v` it absorbs is non-negative for a
/// passive table. Beyond the table's ends the force is **extrapolated linearly** with the slope
/// of the first/last segment (a real damper keeps resisting harder; clamping would make it
/// force-free at high speed). The slopes are precomputed so [`Damper::force_n`] does no
/// division and no allocation.
#[derive(Debug, Clone, PartialEq)]
pub struct Damper {
    velocity_m_s: Vec<f64>,
    force_n: Vec<f64>,
    slope_n_s_per_m: Vec<f64>,
}

impl Damper {
    /// Builds the table. `airsus-data` guarantees at least two points with strictly increasing
    /// velocities; a table violating that (built in code) degrades to zero force rather than
    /// panicking.
    pub fn new(table: &DamperTable) -> Self {
        let n = table.velocity_m_s.len().min(table.force_n.len());
        let velocity_m_s = table.velocity_m_s[..n].to_vec();
        let force_n = table.force_n[..n].to_vec();
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
        Self::new(&DamperTable {
            velocity_m_s: vec![-1.0, 1.0],
            force_n: vec![0.0, 0.0],
        })
    }

    /// Force, N, at extension velocity `velocity_m_s`, m/s.
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
        self.force_n[i] + self.slope_n_s_per_m[i] * (velocity_m_s - v[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference() -> Damper {
        Damper::new(&DamperTable {
            velocity_m_s: vec![-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0],
            force_n: vec![-6000.0, -4000.0, -1500.0, 0.0, 3000.0, 9000.0, 13000.0],
        })
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
    fn extrapolates_linearly_beyond_the_ends() {
        let d = reference();
        // last segment slope (13000-9000)/0.5 = 8000 N s/m: at 1.5 m/s 13000 + 4000
        assert!((d.force_n(1.5) - 17_000.0).abs() < 1e-9);
        // first segment slope (-4000+6000)/0.5 = 4000 N s/m: at -2 m/s -6000 - 4000
        assert!((d.force_n(-2.0) + 10_000.0).abs() < 1e-9);
    }

    #[test]
    fn zero_table_and_degenerate_table_give_no_force() {
        assert_eq!(Damper::zero().force_n(3.0), 0.0);
        let d = Damper::new(&DamperTable {
            velocity_m_s: vec![0.0],
            force_n: vec![1.0],
        });
        assert_eq!(d.force_n(1.0), 0.0);
    }
}
