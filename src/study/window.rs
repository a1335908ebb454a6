//! The η window: the interval around −1 where equal dwell stays at or below a nonuniformity
//! threshold, with the tool speed held and the workpiece speed −η·tool.
//!
//! N(η) is the equal-dwell nonuniformity. From η = −1 we step outward on each side until N
//! exceeds the threshold, then find the crossing in the last step by the Illinois variant of
//! regula falsi to |Δη| ≤ 1e-10 or |N − threshold| ≤ 1e-9. The first step is |η + 1| = 0.01;
//! each next one goes to where the line through the last two values reaches the threshold,
//! 2 % beyond it (N grows about linearly in |η + 1| near −1, so that step usually brackets the
//! crossing closely), but at least 1.5 and at most 4 times as far from −1 as the last.
//! On the high side η stays below 0 (η = 0 stops the workpiece); a side that never crosses
//! within |η + 1| ≤ 50 (or before η = −1e-6, or before the workpiece speed leaves the model's
//! domain) has no bound.

use super::equal_dwell::{canonical_translation, nonuniformity, Frame};
use crate::physics::roots::illinois;
use crate::physics::{Process, ProcessSpec};

/// The η interval, each end `None` when equal dwell stays below the threshold all the way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EtaWindow {
    pub low: Option<f64>,
    pub high: Option<f64>,
    pub threshold: f64,
}

/// Equal-dwell nonuniformity at η with the tool speed of `spec` held; `None` where the
/// workpiece speed −η·tool leaves the model's domain.
fn n_at(spec: &ProcessSpec, eta: f64, frame: Frame) -> Option<f64> {
    let process = Process::new(spec.with_eta(eta)).ok()?;
    Some(nonuniformity(&process, frame).unwrap_or(f64::INFINITY))
}

/// The window around −1 for the geometry and pressure model of `process`, or `None` when
/// equal dwell at η = −1 itself is above the threshold.
///
/// Equal-dwell nonuniformity is a ratio of removals, and removal is proportional to K·P and,
/// at a fixed η, to the speed scale (both speeds scaled by s scale every sliding velocity by
/// s; reversing both mirrors the motion). So N(η) — and the window — depend on the geometry
/// (radii, pressure model), the frame and the threshold only. It is computed at the canonical
/// setting ([`canonical_translation`]: tool 100 r/min, fixed K and P), which makes it exactly
/// the same, bit for bit, for every process of that geometry: it can be cached on what it
/// depends on and still answer deterministically.
pub fn eta_window(process: &Process, frame: Frame, threshold: f64) -> Option<EtaWindow> {
    window_at(&canonical_translation(process.spec()), frame, threshold)
}

/// The window with the tool speed of `spec` (≠ 0) held.
pub(super) fn window_at(spec: &ProcessSpec, frame: Frame, threshold: f64) -> Option<EtaWindow> {
    let f = |eta: f64| n_at(spec, eta, frame).map(|n| n - threshold);
    let at_minus_one = f(-1.0)?;
    if at_minus_one > 0.0 {
        return None;
    }
    let side = |direction: f64| -> Option<f64> {
        // (|η + 1|, N − threshold) at the last point inside the window.
        let mut inside = (0.0, at_minus_one);
        let mut distance: f64 = 0.01;
        loop {
            let mut eta = -1.0 + direction * distance;
            if direction > 0.0 && eta >= -1e-6 {
                eta = -1e-6;
            }
            // Leaving the domain (workpiece beyond the speed limit) ends the search: no bound.
            let value = f(eta)?;
            if value > 0.0 {
                let finite = |x| f(x).unwrap_or(f64::INFINITY);
                let last = (-1.0 + direction * inside.0, inside.1);
                return Some(illinois(&finite, last, (eta, value), 1e-10, 1e-9));
            }
            if (direction > 0.0 && eta >= -1e-6) || distance > 50.0 {
                return None;
            }
            let slope = (value - inside.1) / (distance - inside.0);
            let reach = distance - 1.02 * value / slope;
            inside = (distance, value);
            distance = if slope > 0.0 {
                reach.clamp(1.5 * distance, 4.0 * distance)
            } else {
                4.0 * distance
            };
        }
    };
    Some(EtaWindow {
        low: side(-1.0),
        high: side(1.0),
        threshold,
    })
}
