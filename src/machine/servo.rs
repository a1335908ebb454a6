//! Whether a servo axis can follow a periodic motion, harmonic by harmonic (the slow-tool-servo
//! rule).
//!
//! A harmonic of amplitude A (mm) at frequency f (Hz) is A·cos(2πft + ψ): it spans 2A of
//! travel, peaks at 2πf·A of velocity and 4π²f²·A of acceleration. An axis of travel L,
//! velocity v_max and acceleration a_max follows it when
//!
//! ```text
//! A ≤ min{ L/2,  v_max/(2πf),  a_max/(4π²f²) }
//! ```
//!
//! On a part turning on C at n r/min, harmonic m of the motion per turn has f = m·n/60, so
//! the velocity allows n ≤ 60·v_max/(2π·m·A) and the acceleration n ≤ (60/(2π·m))·√(a_max/A):
//! the largest C speed of a ring is the least of these over its harmonics, and no speed helps
//! a harmonic that needs more than the travel. The rule is per harmonic, as it is stated: the
//! harmonics' peaks add at worst, which the executed motion's own check (its blocks against
//! every limit) then judges.

use std::f64::consts::PI;

use super::limits::AxisLimits;

/// Amplitudes below this (mm, a picometre) are rounding, not motion: they bound nothing.
pub const NEGLIGIBLE_AMPLITUDE_MM: f64 = 1e-9;

/// Which limit sets a harmonic's largest C speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoLimit {
    Velocity,
    Acceleration,
}

/// The largest C speed one axis allows a ring, and what sets it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSpeed {
    /// r/min; infinite when no harmonic is limited.
    pub largest_c_rpm: f64,
    /// The harmonic (m ≥ 1) and the limit that set it; `None` when nothing limits.
    pub binding: Option<(usize, ServoLimit)>,
}

/// A harmonic that no C speed lets the axis follow: it needs more than the travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TravelBreach {
    pub harmonic: usize,
    pub amplitude_mm: f64,
    pub half_travel_mm: f64,
}

/// The largest C speed (r/min) at which `axis` follows a motion whose harmonics m = 1, 2, …
/// have the amplitudes `amplitudes_mm[m − 1]` (the module's rule), or the first harmonic that
/// needs more than the travel.
pub fn largest_c_speed(
    amplitudes_mm: &[f64],
    axis: &AxisLimits,
) -> Result<ServoSpeed, TravelBreach> {
    let half_travel = match (axis.min, axis.max) {
        (Some(lo), Some(hi)) => Some(0.5 * (hi - lo)),
        _ => None,
    };
    let mut best = ServoSpeed {
        largest_c_rpm: f64::INFINITY,
        binding: None,
    };
    for (k, &a) in amplitudes_mm.iter().enumerate() {
        let m = k + 1;
        if a < NEGLIGIBLE_AMPLITUDE_MM {
            continue;
        }
        if let Some(half) = half_travel.filter(|&h| a > h) {
            return Err(TravelBreach {
                harmonic: m,
                amplitude_mm: a,
                half_travel_mm: half,
            });
        }
        let per = 60.0 / (2.0 * PI * m as f64);
        let candidates = [
            axis.max_velocity_per_min
                .map(|v| (per * (v / 60.0) / a, ServoLimit::Velocity)),
            axis.max_acceleration_per_s2
                .map(|acc| (per * (acc / a).sqrt(), ServoLimit::Acceleration)),
        ];
        for (rpm, limit) in candidates.into_iter().flatten() {
            if rpm < best.largest_c_rpm {
                best = ServoSpeed {
                    largest_c_rpm: rpm,
                    binding: Some((m, limit)),
                };
            }
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the speed the rule gives, the binding harmonic's sinusoid reaches its limit exactly
    /// (peak velocity 2πf·A = v_max, or 4π²f²·A = a_max, f = m·n/60), and every other
    /// harmonic stays within both; a travel of less than 2A is refused naming the harmonic.
    #[test]
    fn the_speed_puts_the_binding_harmonic_at_its_limit() {
        let amplitudes = [0.8, 0.05, 0.3, 0.0, 0.02];
        for (v, a) in [
            (Some(3000.0), Some(500.0)),
            (Some(300.0), Some(5000.0)),
            (None, Some(100.0)),
        ] {
            let axis = AxisLimits {
                min: Some(-5.0),
                max: Some(5.0),
                max_velocity_per_min: v,
                max_acceleration_per_s2: a,
            };
            let speed = largest_c_speed(&amplitudes, &axis).unwrap();
            let n = speed.largest_c_rpm;
            assert!(n.is_finite());
            let (m, limit) = speed.binding.unwrap();
            let mut reached = false;
            for (k, &amp) in amplitudes.iter().enumerate() {
                let f = (k + 1) as f64 * n / 60.0;
                let peak_v = 2.0 * PI * f * amp * 60.0;
                let peak_a = 4.0 * PI * PI * f * f * amp;
                if let Some(v) = v {
                    assert!(peak_v <= v * (1.0 + 1e-12), "{k}: {peak_v} > {v}");
                }
                if let Some(a) = a {
                    assert!(peak_a <= a * (1.0 + 1e-12), "{k}: {peak_a} > {a}");
                }
                if k + 1 == m {
                    let (peak, max) = match limit {
                        ServoLimit::Velocity => (peak_v, v.unwrap()),
                        ServoLimit::Acceleration => (peak_a, a.unwrap()),
                    };
                    reached = (peak - max).abs() <= 1e-12 * max;
                }
            }
            assert!(reached, "{speed:?}");
        }
        let short = AxisLimits {
            min: Some(0.0),
            max: Some(1.0),
            max_velocity_per_min: None,
            max_acceleration_per_s2: None,
        };
        assert_eq!(
            largest_c_speed(&amplitudes, &short),
            Err(TravelBreach {
                harmonic: 1,
                amplitude_mm: 0.8,
                half_travel_mm: 0.5
            })
        );
        // Nothing limits an unlimited axis.
        let free = largest_c_speed(&amplitudes, &AxisLimits::default()).unwrap();
        assert_eq!(free.largest_c_rpm, f64::INFINITY);
        assert_eq!(free.binding, None);
    }
}
