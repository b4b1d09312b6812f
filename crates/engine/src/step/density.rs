//! How a region's leaf-pair count grows with its margin near the tool, as last seen: sizes the
//! next region so that it holds about its target count ([`BALL_PAIR_TARGET`](super::BALL_PAIR_TARGET)
//! pairs for a ball region, [`PAIR_TARGET`](super::PAIR_TARGET) for a path or a probe).
//!
//! Over a curved or sparse contact the count grows about linearly with the margin; over two
//! bumpy flat faces pressed together it grows as a high power of it (every leaf of the face is
//! a few tenths of a millimetre from the other face: measured on a depth-5 puck on the plate,
//! 52 pairs at 0.05 mm, 516 at 0.12, 2 582 at 0.18, 11 494 at 0.3). A linear guess from a
//! small region then asks for a region of ten thousand pairs, whose traversal outlasts the
//! frame. So the growth exponent is measured between detections at different margins, and a
//! region grows from the last one by the power law, shrinks by the (more cautious) linear rule.

/// Fewest pairs in both detections for their ratio to measure the growth exponent.
const MIN_PAIRS_TO_MEASURE: f64 = 16.0;

/// Least ratio of two detections' margins (as `|ln m_b / m_a|`) that measures the exponent.
const MIN_LOG_MARGIN_RATIO: f64 = 0.1;

/// Bounds of the growth exponent (1: a line of contact growing sideways; 4: measured between
/// 0.12 and 0.18 mm on the flat-on-flat puck). Until two detections have measured it, the
/// largest is assumed: a contact resting at one margin tells nothing of how it grows.
const MIN_EXPONENT: f64 = 1.0;
const MAX_EXPONENT: f64 = 4.0;

/// A last count that has faded below this many pairs (in free space) is forgotten.
const FORGOTTEN_PAIRS: f64 = 1e-3;

/// Share of the exponent's excess over 1 kept per measurement that shows less: it falls back
/// slowly (a contact that was flat a moment ago may be again).
const EXPONENT_MEMORY: f64 = 0.95;

/// Share of the pair density per mm kept per detection: a denser contact is remembered at once,
/// a sparser one believed slowly.
const DENSITY_MEMORY: f64 = 0.9;

/// Pair counts against margins, as last seen.
#[derive(Clone, Copy, Debug)]
pub(super) struct PairDensity {
    /// Leaf pairs per mm of margin, slowly forgotten.
    per_mm: f64,
    /// The same over regions along a path (per mm of their width; 0 until one is seen).
    path_per_mm: f64,
    /// Margin (mm) and pair count of the last detection that found pairs.
    margin: f64,
    pairs: f64,
    /// Pairs grow about as the margin to this power (`None`: not measured yet).
    exponent: Option<f64>,
}

impl Default for PairDensity {
    fn default() -> Self {
        Self {
            per_mm: 0.0,
            path_per_mm: 0.0,
            margin: 0.0,
            pairs: 0.0,
            exponent: None,
        }
    }
}

impl PairDensity {
    /// Records a detection of `pairs` leaf pairs within `margin` mm (of the pose, or `along`
    /// a path: then `margin` is the path region's width, and the count measures only the
    /// density along paths).
    pub(super) fn record(&mut self, margin: f64, pairs: usize, along: bool) {
        if pairs == 0 || margin.is_nan() || margin <= 0.0 {
            // Free space: the memories fade, as if the last count had been fewer pairs at a
            // wider margin (until it is none).
            self.per_mm *= DENSITY_MEMORY;
            self.path_per_mm *= DENSITY_MEMORY;
            self.pairs *= DENSITY_MEMORY;
            self.margin /= DENSITY_MEMORY;
            if self.pairs < FORGOTTEN_PAIRS {
                self.pairs = 0.0;
            }
            return;
        }
        let p = pairs as f64;
        self.per_mm = (p / margin).max(DENSITY_MEMORY * self.per_mm);
        if along {
            self.path_per_mm = (p / margin).max(DENSITY_MEMORY * self.path_per_mm);
            return;
        }
        let log_ratio = (margin / self.margin).ln();
        if self.pairs >= MIN_PAIRS_TO_MEASURE
            && p >= MIN_PAIRS_TO_MEASURE
            && log_ratio.abs() >= MIN_LOG_MARGIN_RATIO
        {
            let seen = (p / self.pairs).ln() / log_ratio;
            if seen.is_finite() {
                let seen = seen.clamp(MIN_EXPONENT, MAX_EXPONENT);
                self.exponent = Some(match self.exponent {
                    Some(k) => seen.max(MIN_EXPONENT + EXPONENT_MEMORY * (k - MIN_EXPONENT)),
                    None => seen,
                });
            }
        }
        self.margin = margin;
        self.pairs = p;
    }

    /// Largest margin (mm) expected to hold at most `target` pairs: the linear rule, and when
    /// the last detection held fewer, no more than its margin grown by the power law.
    pub(super) fn margin_for(&self, target: f64) -> f64 {
        let linear = self.linear_margin_for(target);
        if self.pairs > 0.0 && self.pairs < target {
            let k = self.exponent.unwrap_or(MAX_EXPONENT);
            linear.min(self.margin * (target / self.pairs).powf(1.0 / k))
        } else {
            linear
        }
    }

    /// Largest margin (mm) expected to hold at most `target` pairs by the linear rule alone.
    fn linear_margin_for(&self, target: f64) -> f64 {
        target / self.per_mm.max(1e-9)
    }

    /// Longest path region (length and width together, mm) expected to hold about `target`
    /// pairs: by the density along paths once one has been measured (a sliding contact's
    /// pairs come in at its leading edge, about linearly with the length), else the linear
    /// rule.
    pub(super) fn path_margin_for(&self, target: f64) -> f64 {
        if self.path_per_mm > 0.0 {
            target / self.path_per_mm
        } else {
            self.linear_margin_for(target)
        }
    }

    /// The growth exponent as measured (1 before).
    #[cfg(test)]
    fn exponent(&self) -> f64 {
        self.exponent.unwrap_or(MIN_EXPONENT)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl PairDensity {
        /// A detection at a pose.
        fn record_at(&mut self, margin: f64, pairs: usize) {
            self.record(margin, pairs, false);
        }
    }

    /// Pairs within `m` mm of a contact whose count grows as `c m^k`.
    fn count(c: f64, k: f64, m: f64) -> usize {
        (c * m.powf(k)).round() as usize
    }

    #[test]
    fn a_linear_contact_keeps_the_linear_rule() {
        let mut d = PairDensity::default();
        d.record_at(0.2, count(1000.0, 1.0, 0.2));
        d.record_at(0.4, count(1000.0, 1.0, 0.4));
        assert!((d.exponent() - 1.0).abs() < 0.05, "{}", d.exponent());
        // 400 pairs at 0.4 mm: 1 500 pairs at 1.5 mm.
        assert!(
            (d.margin_for(1500.0) - 1.5).abs() < 0.02,
            "{}",
            d.margin_for(1500.0)
        );
    }

    #[test]
    fn a_flat_contact_grows_its_region_by_the_power_law() {
        // The puck's measured counts: 516 pairs at 0.12 mm, 2 582 at 0.18.
        let mut d = PairDensity::default();
        d.record_at(0.18, 2582);
        // The denser detection's density is forgotten over a dozen detections at 0.12 mm.
        for _ in 0..12 {
            d.record_at(0.12, 516);
        }
        let k = d.exponent();
        assert!(k > 3.5 && k <= 4.0, "{k}");
        // The linear rule would ask for 0.35 mm (over 10 000 pairs there); the power law
        // asks for the margin where c m^k = 1 500.
        let m = d.margin_for(1500.0);
        let c = 516.0 / 0.12f64.powf(k);
        assert!((c * m.powf(k) - 1500.0).abs() < 1.0, "{m}");
        assert!(m < 0.2, "{m}");
    }

    #[test]
    fn an_unmeasured_contact_grows_as_the_flattest_would() {
        // Resting at one margin: 125 pairs at 0.069 mm, again and again.
        let mut d = PairDensity::default();
        for _ in 0..5 {
            d.record_at(0.069, 125);
        }
        let m = d.margin_for(1500.0);
        assert!(
            (125.0 * (m / 0.069).powf(MAX_EXPONENT) - 1500.0).abs() < 1e-6,
            "{m}"
        );
    }

    #[test]
    fn a_denser_contact_shrinks_the_region_linearly() {
        let mut d = PairDensity::default();
        d.record_at(0.12, 516);
        d.record_at(0.18, 2582);
        // Past the target the linear rule (the smaller margin) holds.
        let m = d.margin_for(1500.0);
        assert!((m - 1500.0 / (2582.0 / 0.18)).abs() < 1e-9, "{m}");
    }

    #[test]
    fn the_exponent_falls_back_slowly_and_free_space_forgets_the_density() {
        let mut d = PairDensity::default();
        d.record_at(0.12, 516);
        d.record_at(0.18, 2582);
        let k = d.exponent();
        d.record_at(0.36, 2 * 2582);
        assert!((d.exponent() - (1.0 + EXPONENT_MEMORY * (k - 1.0))).abs() < 1e-12);
        // (Below the last count the linear rule holds.)
        let before = d.margin_for(100.0);
        d.record_at(0.3, 0);
        assert!((d.margin_for(100.0) - before / DENSITY_MEMORY).abs() < 1e-9 * before);
        // A while in free space: the last count is forgotten, only the (faded) linear rule
        // is left.
        for _ in 0..150 {
            d.record_at(0.3, 0);
        }
        assert_eq!(d.margin_for(1500.0), 1500.0 / d.per_mm);
        // Too few pairs, or the same margin, measure nothing.
        let mut e = PairDensity::default();
        e.record_at(0.1, 4);
        e.record_at(0.3, 400);
        assert_eq!(e.exponent, None);
        e.record_at(0.31, 4000);
        assert_eq!(e.exponent, None);
    }
}
