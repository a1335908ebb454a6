//! The feed-axis motion a dwell plan implies.
//!
//! The tool crosses segment j, between positions r1_j and r1_{j+1}, in half of each end's
//! dwell: T_j = (t_j + t_{j+1})/2 (s), so its mean feed there is v_j = Δr_j / T_j (reported in
//! mm/min). The feed changes from v_j to v_{j+1} over the time between the two segments'
//! midpoints, (T_j + T_{j+1})/2, which gives the feed acceleration
//! a_j = (v_{j+1} − v_j) / ((T_j + T_{j+1})/2) in mm/s².
//!
//! On evenly spaced positions (spacing h) v_{j+1} − v_j = h·(T_j − T_{j+1})/(T_j·T_{j+1}) and
//! |T_j − T_{j+1}| = |t_j − t_{j+2}|/2 ≤ δ when neighbouring dwells differ by at most δ, so
//! |a_j| ≤ h·δ / T_min³: the dwell-change bound is a linear surrogate for an acceleration limit.

/// Feeds and accelerations of a plan. A segment whose two ends both have zero dwell is crossed
/// in no time (the axis would jump): its feed is `None` and so are the peaks.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Mean feed on each segment, mm/min (one fewer than positions).
    pub segment_feed_mm_per_min: Vec<Option<f64>>,
    /// Largest segment feed, mm/min; `None` if some segment is crossed in no time or there is
    /// no segment.
    pub peak_feed_mm_per_min: Option<f64>,
    /// Largest |feed change| per unit time between consecutive segments, mm/s²; `None` if some
    /// segment is crossed in no time, `Some(0)` with fewer than two segments.
    pub peak_acceleration_mm_per_s2: Option<f64>,
}

impl Motion {
    pub fn of_plan(positions_mm: &[f64], dwell_s: &[f64]) -> Self {
        assert_eq!(positions_mm.len(), dwell_s.len());
        let times: Vec<f64> = dwell_s.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        let feeds_mm_per_s: Vec<Option<f64>> = positions_mm
            .windows(2)
            .zip(&times)
            .map(|(w, &t)| (t > 0.0).then(|| (w[1] - w[0]) / t))
            .collect();
        let all: Option<Vec<f64>> = feeds_mm_per_s.iter().copied().collect();
        let peak_feed = all
            .as_ref()
            .filter(|v| !v.is_empty())
            .map(|v| 60.0 * v.iter().fold(0.0_f64, |m, &x| m.max(x)));
        let peak_acceleration = all.as_ref().map(|v| {
            v.windows(2)
                .zip(times.windows(2))
                .map(|(f, t)| (f[1] - f[0]).abs() / (0.5 * (t[0] + t[1])))
                .fold(0.0_f64, f64::max)
        });
        Motion {
            segment_feed_mm_per_min: feeds_mm_per_s.iter().map(|v| v.map(|x| 60.0 * x)).collect(),
            peak_feed_mm_per_min: peak_feed,
            peak_acceleration_mm_per_s2: peak_acceleration,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_feed_has_no_acceleration() {
        // 1 mm apart, 6 s each: every segment takes 6 s → 10 mm/min, no acceleration.
        let m = Motion::of_plan(&[0.0, 1.0, 2.0, 3.0], &[6.0; 4]);
        assert_eq!(m.segment_feed_mm_per_min, vec![Some(10.0); 3]);
        assert_eq!(m.peak_feed_mm_per_min, Some(10.0));
        assert_eq!(m.peak_acceleration_mm_per_s2, Some(0.0));
    }

    #[test]
    fn acceleration_is_feed_change_over_time_between_segments() {
        // Segment times 1 s and 2 s: feeds 1 and 0.5 mm/s; the midpoints are 1.5 s apart.
        let m = Motion::of_plan(&[0.0, 1.0, 2.0], &[1.0, 1.0, 3.0]);
        assert_eq!(m.segment_feed_mm_per_min, vec![Some(60.0), Some(30.0)]);
        let a = m.peak_acceleration_mm_per_s2.unwrap();
        assert!((a - 0.5 / 1.5).abs() < 1e-15, "{a}");
        // And the documented bound h·δ/T_min³ holds (h = 1, δ = 2, T_min = 1).
        assert!(a <= 2.0);
    }

    #[test]
    fn zero_time_segments_have_no_feed() {
        let m = Motion::of_plan(&[0.0, 1.0, 2.0], &[0.0, 0.0, 4.0]);
        assert_eq!(m.segment_feed_mm_per_min, vec![None, Some(30.0)]);
        assert_eq!(m.peak_feed_mm_per_min, None);
        assert_eq!(m.peak_acceleration_mm_per_s2, None);
        assert_eq!(Motion::of_plan(&[1.0], &[1.0]).peak_feed_mm_per_min, None);
    }
}
