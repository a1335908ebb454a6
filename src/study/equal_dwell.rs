//! Equal dwell: one constant-feed pass over [0, L] (see [`super`]), and what it removes.

use crate::physics::{
    ClearAperture, ConstantFeed, PassReading, Process, ProcessSpec, RadialGrid, UniformityMetrics,
};

/// Where a study looks: the radial grid removal is computed on and the clear aperture it is
/// judged over.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    pub grid: &'a RadialGrid,
    pub aperture: &'a ClearAperture,
}

/// The equal-dwell pass for a process and aperture, scaled to remove a mean depth.
#[derive(Debug, Clone, PartialEq)]
pub struct EqualDwell {
    /// The constant-feed pass over [0, L].
    pub pass: ConstantFeed,
    /// Its travel time, s.
    pub total_time_s: f64,
    /// Removal at each grid radius inside the clear aperture, nm (only these are judged, so
    /// only these are computed).
    pub aperture_removal_nm: Vec<f64>,
    pub metrics: UniformityMetrics,
}

/// The η = −1 setting at which the parts of a study that depend only on the geometry are
/// computed: both speeds 100 r/min, K = 1e-13 m²/N, P = 10 kPa (see [`EqualDwell::retimed`]
/// and [`super::eta_window`]).
pub const CANONICAL_RPM: f64 = 100.0;
const CANONICAL_PRESTON: f64 = 1e-13;
const CANONICAL_PRESSURE_KPA: f64 = 10.0;

/// `spec`'s geometry and pressure model at the canonical η = −1 setting.
pub fn canonical_translation(spec: &ProcessSpec) -> ProcessSpec {
    ProcessSpec {
        workpiece_rpm: CANONICAL_RPM,
        tool_rpm: CANONICAL_RPM,
        preston_coefficient_m2_per_n: CANONICAL_PRESTON,
        pressure_kpa: CANONICAL_PRESSURE_KPA,
        ..spec.clone()
    }
}

/// How many times faster `spec` at η = −1 and `speed_rpm` removes than the canonical setting:
/// at η = −1 the rate K·P·|ω|·r1·θ0/π is linear in speed, K and P together.
pub fn translation_rate_factor(spec: &ProcessSpec, speed_rpm: f64) -> f64 {
    (speed_rpm / CANONICAL_RPM)
        * (spec.preston_coefficient_m2_per_n / CANONICAL_PRESTON)
        * (spec.pressure_kpa / CANONICAL_PRESSURE_KPA)
}

/// Path end L = min(outer + r_t, the farthest a pass may run), mm (r_t along the surface on a
/// curved part; see [`Process::pass_reach_mm`]).
pub fn path_end_mm(process: &Process, aperture: &ClearAperture) -> f64 {
    process
        .radius_past_mm(aperture.outer_mm(), process.tool_radius_mm())
        .min(process.pass_reach_mm())
}

/// The pass over [0, L] at 60 mm/min (1 s/mm): every equal-dwell plan is this one scaled, as
/// removal is linear in the dwell density.
fn unit_feed(process: &Process, aperture: &ClearAperture) -> Option<ConstantFeed> {
    ConstantFeed::new(process, 0.0, path_end_mm(process, aperture), 60.0).ok()
}

/// The unit pass as an operator on the frame's grid reads it beside its rows
/// ([`PassReading`]), for [`EqualDwell::read`].
pub fn pass_reading(process: &Process, frame: Frame) -> Option<PassReading> {
    Some(PassReading {
        feed: unit_feed(process, frame.aperture)?,
        rows: frame.grid.rows_in(frame.aperture),
    })
}

impl EqualDwell {
    /// The pass whose mean removal over the aperture is `depth_nm` (> 0). `None` when the
    /// pass removes nothing inside the aperture.
    pub fn for_depth(process: &Process, frame: Frame, depth_nm: f64) -> Option<Self> {
        let unit = unit_feed(process, frame.aperture)?;
        let radii = &frame.grid.radii_mm()[frame.grid.rows_in(frame.aperture)];
        let removal = unit.removal_nm(process, radii);
        Self::from_unit(process, unit, removal, depth_nm)
    }

    /// The pass removing 1 nm on average, its removal read from each radius's running
    /// integral ([`ConstantFeed::removal_read_nm`]): `read` is what an operator's rows read of
    /// [`pass_reading`] beside it (the same bits), or `None` to read it here.
    pub fn read(process: &Process, frame: Frame, read: Option<Vec<f64>>) -> Option<Self> {
        let unit = unit_feed(process, frame.aperture)?;
        let removal = read.unwrap_or_else(|| {
            let radii = &frame.grid.radii_mm()[frame.grid.rows_in(frame.aperture)];
            unit.removal_read_nm(process, radii)
        });
        Self::from_unit(process, unit, removal, 1.0)
    }

    /// The unit pass scaled to remove `depth_nm` on average, from its removal `removal`.
    fn from_unit(
        process: &Process,
        unit: ConstantFeed,
        removal: Vec<f64>,
        depth_nm: f64,
    ) -> Option<Self> {
        if removal.is_empty() {
            return None;
        }
        let mean = UniformityMetrics::of_samples(&removal).mean_nm;
        if !(mean > 0.0 && mean.is_finite()) {
            return None;
        }
        let k = depth_nm / mean;
        let removal_nm: Vec<f64> = removal.iter().map(|z| z * k).collect();
        let pass = unit.with_feed_scaled(1.0 / k);
        Some(EqualDwell {
            metrics: UniformityMetrics::of_samples(&removal_nm),
            total_time_s: pass.total_time_s(process),
            pass,
            aperture_removal_nm: removal_nm,
        })
    }

    /// The constant feed, mm/min of arc.
    pub fn feed_mm_per_min(&self) -> f64 {
        self.pass.feed_mm_per_min()
    }

    /// The same pass removing k times as deep (k > 0): time and removal scale by k, the feed
    /// by 1/k, nonuniformity not at all.
    pub fn scaled(&self, k: f64) -> Self {
        let m = &self.metrics;
        EqualDwell {
            pass: self.pass.with_feed_scaled(1.0 / k),
            total_time_s: self.total_time_s * k,
            aperture_removal_nm: self.aperture_removal_nm.iter().map(|z| z * k).collect(),
            metrics: UniformityMetrics {
                mean_nm: m.mean_nm * k,
                min_nm: m.min_nm * k,
                max_nm: m.max_nm * k,
                pv_nm: m.pv_nm * k,
                rms_nm: m.rms_nm * k,
                ..*m
            },
        }
    }

    /// The same pass on a process that removes `factor` (> 0) times as fast everywhere: the
    /// same removal in 1/factor of the time (feed × factor).
    pub fn retimed(&self, factor: f64) -> Self {
        EqualDwell {
            pass: self.pass.with_feed_scaled(factor),
            total_time_s: self.total_time_s / factor,
            ..self.clone()
        }
    }

    /// Whether every figure is a finite number (retiming by an extreme factor can overflow).
    pub fn is_finite(&self) -> bool {
        self.feed_mm_per_min().is_finite()
            && self.total_time_s.is_finite()
            && self.aperture_removal_nm.iter().all(|z| z.is_finite())
    }

    /// Mean removal rate over the aperture, nm/min.
    pub fn mean_rate_nm_per_min(&self) -> f64 {
        60.0 * self.metrics.mean_nm / self.total_time_s
    }
}

/// Nonuniformity of equal dwell at `process` (scale-free, so no depth is needed); `None` when
/// the pass removes nothing in the aperture.
pub fn nonuniformity(process: &Process, frame: Frame) -> Option<f64> {
    EqualDwell::for_depth(process, frame, 1.0)?
        .metrics
        .nonuniformity
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;

    #[test]
    fn a_pass_removes_its_depth_and_scales_linearly() {
        let process = Process::new(paper_spec(-10.0, 200.0)).unwrap();
        let grid = RadialGrid::default_for(&process);
        let aperture = ClearAperture::new(&process, 0.0, 40.0).unwrap();
        let frame = Frame {
            grid: &grid,
            aperture: &aperture,
        };
        let pass = EqualDwell::for_depth(&process, frame, 100.0).unwrap();
        assert!((pass.metrics.mean_nm - 100.0).abs() < 1e-9);
        // The path runs to outer + r_t = 50 mm at one feed throughout.
        assert_eq!((pass.pass.start_mm(), pass.pass.stop_mm()), (0.0, 50.0));
        let time = 60.0 * 50.0 / pass.feed_mm_per_min();
        assert!((pass.total_time_s - time).abs() < 1e-12 * time);
        let doubled = pass.scaled(2.0);
        let direct = EqualDwell::for_depth(&process, frame, 200.0).unwrap();
        assert!((doubled.metrics.pv_nm - direct.metrics.pv_nm).abs() < 1e-9 * direct.metrics.pv_nm);
        assert!(
            (doubled.feed_mm_per_min() - direct.feed_mm_per_min()).abs()
                < 1e-12 * direct.feed_mm_per_min()
        );
        assert_eq!(doubled.metrics.nonuniformity, pass.metrics.nonuniformity);
    }
}
