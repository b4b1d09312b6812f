//! How a region's leaf-pair count grows with its margin near the tool, as last seen: sizes the
//! next region so that it holds about its target count ([`Tuning::ball_pair_target`]
//! pairs for a ball region, [`Tuning::pair_target`] for a path or a probe).
//!
//! Over a curved or sparse contact the count grows about linearly with the margin; over two
//! bumpy flat faces pressed together, or a shaft's keys landing in its hub's grooves, it grows
//! as a high power of it (every leaf of the face is a few tenths of a millimetre from the
//! other face: measured on a depth-5 puck on the plate, 52 pairs at 0.05 mm, 516 at 0.12,
//! 2 582 at 0.18, 11 494 at 0.3; on the spline's landing, 7 at 0.05 mm, 500 at 0.127, 2 879
//! at 0.268). A linear guess from a small region then asks for a region of ten thousand
//! pairs, whose traversal outlasts the frame, and a linear guess from a large one asks for a
//! region of a few pairs, then crawls back. So the growth exponent is measured between
//! detections at different margins, and a region is sized from the last detection and from
//! the densest one remembered by that power law, both ways.

/// Fewest pairs in both detections for their ratio to measure the growth exponent.
const MIN_PAIRS_TO_MEASURE: f64 = 16.0;

/// Least ratio of two detections' margins (as `|ln m_b / m_a|`) that measures the exponent.
const MIN_LOG_MARGIN_RATIO: f64 = 0.1;

/// Bounds of the growth exponent (1: a line of contact growing sideways; 4: two bumpy flat
/// faces pressed together, measured between 0.12 and 0.18 mm: design-notes §Regions, trust
/// boxes and passes). Until two detections have measured it, a
/// region grows as the steepest contact would and shrinks as the flattest would (both the
/// cautious side): a contact resting at one margin tells nothing of how it grows.
const MIN_EXPONENT: f64 = 1.0;
const MAX_EXPONENT: f64 = 4.0;

/// A last count that has faded below this many pairs (in free space) is forgotten.
const FORGOTTEN_PAIRS: f64 = 1e-3;

/// Share of the exponent's excess over 1 kept per measurement that shows less: it falls back
/// slowly (a contact that was flat a moment ago may be again).
const EXPONENT_MEMORY: f64 = 0.95;

/// Share of the densest detection's count kept per detection: a denser contact is remembered
/// at once, a sparser one believed slowly.
const DENSITY_MEMORY: f64 = 0.9;

/// A detection: its margin (mm) and leaf-pair count.
#[derive(Clone, Copy, Debug, Default)]
struct Count {
    margin: f64,
    pairs: f64,
    /// Along a path (`margin` its width).
    along: bool,
}

/// Pair counts against margins, as last seen.
#[derive(Clone, Copy, Debug)]
pub(super) struct PairDensity {
    /// Leaf pairs per mm of margin, slowly forgotten (the paths' rule before one is seen).
    per_mm: f64,
    /// The same over regions along a path (per mm of their width; 0 until one is seen).
    path_per_mm: f64,
    /// The last detection that found pairs (at a pose or along a path), fading in free space.
    last: Count,
    /// The last detection at a pose that found pairs: the exponent is measured against it.
    last_ball: Count,
    /// The densest detection at a pose by the growth law, its count fading.
    densest: Count,
    /// Pairs grow about as the margin to this power (`None`: not measured yet).
    exponent: Option<f64>,
}

impl Default for PairDensity {
    fn default() -> Self {
        Self {
            per_mm: 0.0,
            path_per_mm: 0.0,
            last: Count::default(),
            last_ball: Count::default(),
            densest: Count::default(),
            exponent: None,
        }
    }
}

impl PairDensity {
    /// Records a detection of `pairs` leaf pairs within `margin` mm (of the pose, or `along`
    /// a path: then `margin` is the path region's width, and its count, a superset of a ball's
    /// of that width at the path's start, sizes the next ball region as the last count (the
    /// safe side) but measures no exponent and is not remembered as the densest; it also
    /// measures the density along paths).
    pub(super) fn record(&mut self, margin: f64, pairs: usize, along: bool) {
        self.densest.pairs *= DENSITY_MEMORY;
        if pairs == 0 || margin.is_nan() || margin <= 0.0 {
            // Free space: the memories fade, as if the last count had been fewer pairs at a
            // wider margin (until it is none).
            self.per_mm *= DENSITY_MEMORY;
            self.path_per_mm *= DENSITY_MEMORY;
            self.last.pairs *= DENSITY_MEMORY;
            self.last.margin /= DENSITY_MEMORY;
            if self.last.pairs < FORGOTTEN_PAIRS {
                self.last = Count::default();
            }
            if self.densest.pairs < FORGOTTEN_PAIRS {
                self.densest = Count::default();
            }
            return;
        }
        let seen = Count {
            margin,
            pairs: pairs as f64,
            along,
        };
        self.per_mm = (seen.pairs / margin).max(DENSITY_MEMORY * self.per_mm);
        self.last = seen;
        if along {
            self.path_per_mm = (seen.pairs / margin).max(DENSITY_MEMORY * self.path_per_mm);
            return;
        }
        let log_ratio = (margin / self.last_ball.margin).ln();
        if self.last_ball.pairs >= MIN_PAIRS_TO_MEASURE
            && seen.pairs >= MIN_PAIRS_TO_MEASURE
            && log_ratio.abs() >= MIN_LOG_MARGIN_RATIO
        {
            let k = (seen.pairs / self.last_ball.pairs).ln() / log_ratio;
            if k.is_finite() {
                let k = k.clamp(MIN_EXPONENT, MAX_EXPONENT);
                self.exponent = Some(match self.exponent {
                    Some(old) => k.max(MIN_EXPONENT + EXPONENT_MEMORY * (old - MIN_EXPONENT)),
                    None => k,
                });
            }
        }
        self.last_ball = seen;
        // Denser than the memory: it would hold more pairs at the memory's margin.
        if self.densest.pairs <= 0.0
            || self.count_at(seen, self.densest.margin) >= self.densest.pairs
        {
            self.densest = seen;
        }
    }

    /// Largest margin (mm) expected to hold at most `target` pairs: the least of the last
    /// detection's and the densest one's margins, each grown or shrunk to `target` by the
    /// power law.
    pub(super) fn margin_for(&self, target: f64) -> f64 {
        let mut margin = f64::INFINITY;
        for count in [self.last, self.densest] {
            if count.pairs > 0.0 {
                margin = margin.min(self.margin_from(count, target));
            }
        }
        margin
    }

    /// Largest margin (mm) of a free-space probe expected to hold at most `target` pairs:
    /// grown from the last and the densest counts as the steepest contact would, and no more
    /// than the linear rule (pairs per mm of every detection, slowly forgotten). A tool lifted
    /// off a flat face meets its bumps again at the lift plus their own growth (the dense puck
    /// lifted ~0.05 mm held 9 pairs within 0.04 mm and 11 351 within 0.3), so a measured
    /// exponent, true at rest, would probe far too wide.
    pub(super) fn probe_margin_for(&self, target: f64) -> f64 {
        let mut margin = target / self.per_mm.max(1e-9);
        for count in [self.last, self.densest] {
            if count.pairs > 0.0 {
                let k = if target > count.pairs {
                    MAX_EXPONENT
                } else {
                    self.exponent.unwrap_or(MIN_EXPONENT)
                };
                margin = margin.min(count.margin * (target / count.pairs).powf(1.0 / k));
            }
        }
        margin
    }

    /// The margin (mm) where a contact that held `count` holds `target` pairs by the power
    /// law: growing, at the measured exponent (the steepest until measured); shrinking, at the
    /// measured exponent (the flattest until measured).
    fn margin_from(&self, count: Count, target: f64) -> f64 {
        let k = match self.exponent {
            // A path's count tells nothing of how a ball's grows.
            Some(k) if !count.along || target < count.pairs => k,
            None if target < count.pairs => MIN_EXPONENT,
            _ => MAX_EXPONENT,
        };
        count.margin * (target / count.pairs).powf(1.0 / k)
    }

    /// Pairs expected within `margin` mm of a contact that held `count`, by the power law at
    /// the measured exponent (1 until measured).
    fn count_at(&self, count: Count, margin: f64) -> f64 {
        count.pairs * (margin / count.margin).powf(self.exponent.unwrap_or(MIN_EXPONENT))
    }

    /// Longest path region (length and width together, mm) expected to hold about `target`
    /// pairs: by the density along paths once one has been measured (a sliding contact's
    /// pairs come in at its leading edge, about linearly with the length), else by the linear
    /// density of every detection.
    pub(super) fn path_margin_for(&self, target: f64) -> f64 {
        let per_mm = if self.path_per_mm > 0.0 {
            self.path_per_mm
        } else {
            self.per_mm
        };
        target / per_mm.max(1e-9)
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
        // 400 pairs at 0.4 mm: 1 500 pairs at 1.5 mm, and 100 at 0.1 mm.
        assert!(
            (d.margin_for(1500.0) - 1.5).abs() < 0.02,
            "{}",
            d.margin_for(1500.0)
        );
        assert!(
            (d.margin_for(100.0) - 0.1).abs() < 0.002,
            "{}",
            d.margin_for(100.0)
        );
    }

    #[test]
    fn a_flat_contact_grows_its_region_by_the_power_law() {
        // The puck's measured counts: 2 582 pairs at 0.18 mm, then 516 at 0.12.
        let mut d = PairDensity::default();
        d.record_at(0.18, 2582);
        d.record_at(0.12, 516);
        let k = d.exponent();
        assert!(k > 3.5 && k <= 4.0, "{k}");
        // The linear rule would ask for 0.35 mm (over 10 000 pairs there); the power law
        // asks for the margin where c m^k = 1 500, at once (the denser count, remembered, is
        // on the same curve).
        let m = d.margin_for(1500.0);
        let c = 516.0 / 0.12f64.powf(k);
        assert!((c * m.powf(k) - 1500.0).abs() < 1.0, "{m}");
        assert!(m < 0.2, "{m}");
    }

    #[test]
    fn an_unmeasured_contact_grows_as_the_steepest_would_and_shrinks_as_the_flattest() {
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
        assert!((d.margin_for(25.0) - 0.069 / 5.0).abs() < 1e-12);
    }

    #[test]
    fn a_denser_contact_shrinks_the_region_by_the_measured_power_law() {
        // The spline's keys landing in the hub's grooves: counts grow as about the 2.3rd power
        // of the margin between 0.13 and 0.27 mm.
        let mut d = PairDensity::default();
        d.record_at(0.1266, 500);
        d.record_at(0.2684, 2879);
        let k = d.exponent();
        assert!((k - 2.33).abs() < 0.01, "{k}");
        // Back to 500 pairs at once (the linear rule asked for 0.047 mm: 7 pairs, then a
        // dozen regions growing by a tenth each).
        let m = d.margin_for(500.0);
        assert!((m - 0.1266).abs() < 1e-3, "{m}");
        // Sparser counts after it are believed slowly: the densest fades by a tenth per
        // detection.
        d.record_at(0.2684, 1000);
        let grown = d.margin_for(500.0);
        let expected = 0.2684 * (500.0 / (DENSITY_MEMORY * 2879.0)).powf(1.0 / d.exponent());
        assert!((grown - expected).abs() < 1e-9, "{grown} {expected}");
    }

    #[test]
    fn a_path_count_sizes_the_next_ball_as_the_steepest_contact_would() {
        let mut d = PairDensity::default();
        d.record_at(0.2, count(1000.0, 1.0, 0.2));
        d.record_at(0.4, count(1000.0, 1.0, 0.4));
        let k = d.exponent();
        // 127 pairs along a path 0.12 mm wide: a ball grows from it at the largest exponent,
        // and nothing is measured from it.
        d.record(0.12, 127, true);
        assert_eq!(d.exponent(), k);
        let m = d.margin_for(500.0);
        assert!(
            (m - 0.12 * (500.0f64 / 127.0).powf(1.0 / MAX_EXPONENT)).abs() < 1e-12,
            "{m}"
        );
        // Past its count, the measured exponent.
        let m = d.margin_for(50.0);
        assert!(
            (m - 0.12 * (50.0f64 / 127.0).powf(1.0 / k)).abs() < 1e-12,
            "{m}"
        );
        // A ball measures its exponent against the last ball, not the path.
        d.record_at(0.3, count(1000.0, 1.0, 0.3));
        assert!((d.exponent() - 1.0).abs() < 0.05, "{}", d.exponent());
    }

    #[test]
    fn the_exponent_falls_back_slowly_and_free_space_forgets_the_density() {
        let mut d = PairDensity::default();
        d.record_at(0.12, 516);
        d.record_at(0.18, 2582);
        let k = d.exponent();
        d.record_at(0.36, 2 * 2582);
        assert!((d.exponent() - (1.0 + EXPONENT_MEMORY * (k - 1.0))).abs() < 1e-12);
        // In free space the last count fades as if it had been fewer pairs at a wider margin.
        let before = d.margin_for(100.0);
        d.record_at(0.3, 0);
        assert!(d.margin_for(100.0) > before);
        // A while there: every count is forgotten.
        for _ in 0..150 {
            d.record_at(0.3, 0);
        }
        assert_eq!(d.margin_for(1500.0), f64::INFINITY);
        // Too few pairs, or the same margin, measure nothing.
        let mut e = PairDensity::default();
        e.record_at(0.1, 4);
        e.record_at(0.3, 400);
        assert_eq!(e.exponent, None);
        e.record_at(0.31, 4000);
        assert_eq!(e.exponent, None);
    }
}
