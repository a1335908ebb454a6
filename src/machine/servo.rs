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
use crate::segments::{harmonics, SegmentLayout};

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

/// What one ring of a layout asks of Z, and the C speed Z allows it.
#[derive(Debug, Clone, PartialEq)]
pub struct RingDemand {
    pub r_mm: f64,
    /// Z's least and greatest value over the turn, mm.
    pub z_range_mm: [f64; 2],
    /// Z's harmonics m = 1 … [`RING_HARMONICS`], amplitude in mm.
    pub amplitudes_mm: Vec<f64>,
    /// The largest C speed at which Z follows every harmonic (the servo rule).
    pub speed: ServoSpeed,
}

/// Why a ring's Z law cannot be followed at any C speed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("ring {ring} (r = {r_mm} mm): Z's harmonic {} needs {:.4} mm of amplitude, more than half Z's travel ({:.4} mm), at any C speed", .breach.harmonic, .breach.amplitude_mm, .breach.half_travel_mm)]
pub struct RingBreach {
    /// The ring's index in the list asked.
    pub ring: usize,
    pub r_mm: f64,
    pub breach: TravelBreach,
}

/// The harmonics of Z a ring's demand lists (a C² law's amplitudes fall as m⁻³: at m = 256
/// they are 1e-7 of the first's).
pub const RING_HARMONICS: usize = 256;

/// The samples per turn the harmonics are taken from (a power of two, 8 per harmonic).
const RING_SAMPLES: usize = 8 * RING_HARMONICS;

/// Each ring's demand on Z (lifted `lift_mm` where a pad of `pad_radius_mm` is clear of the
/// segments) and the C speed `z` allows it;
/// rings that cross no segment are left out. A ring that no C speed allows is refused, naming
/// it and its harmonic.
pub fn ring_demands(
    layout: &SegmentLayout,
    radii_mm: &[f64],
    lift_mm: f64,
    pad_radius_mm: f64,
    z: &AxisLimits,
) -> Result<Vec<RingDemand>, RingBreach> {
    let mut out = Vec::new();
    for (ring, &r_mm) in radii_mm.iter().enumerate() {
        let Some(law) = layout.ring(r_mm, lift_mm, pad_radius_mm) else {
            continue;
        };
        let values = law.samples(RING_SAMPLES);
        let range = values
            .iter()
            .fold([f64::MAX, f64::MIN], |[a, b], &v| [a.min(v), b.max(v)]);
        let amplitudes_mm = harmonics(&values, RING_HARMONICS);
        let speed = largest_c_speed(&amplitudes_mm, z).map_err(|breach| RingBreach {
            ring,
            r_mm,
            breach,
        })?;
        out.push(RingDemand {
            r_mm,
            z_range_mm: range,
            amplitudes_mm,
            speed,
        });
    }
    Ok(out)
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

    /// The paraboloid's four segments: each ring's Z law asks most of its fourth harmonic
    /// (one bump a segment), which sets the largest C speed under Z's limits; a travel of
    /// less than twice that amplitude refuses the ring, naming it and the harmonic. Printed
    /// with `--nocapture`: the table of the docs.
    #[test]
    fn the_segments_rings_are_limited_by_their_fourth_harmonic() {
        let layout = crate::segments::four_paraboloid_segments();
        let z = AxisLimits {
            min: Some(-50.0),
            max: Some(50.0),
            max_velocity_per_min: Some(3000.0),
            max_acceleration_per_s2: Some(500.0),
        };
        let radii = [30.0, 42.0, 55.0, 70.0, 85.0, 98.0, 110.0];
        let demands = ring_demands(&layout, &radii, 0.0, 5.0, &z).unwrap();
        // 30 and 110 mm cross no segment.
        assert_eq!(demands.len(), 5);
        for d in &demands {
            let (m, limit) = d.speed.binding.unwrap();
            assert_eq!(m, 4, "{d:?}");
            let a4 = d.amplitudes_mm[3];
            let expected = match limit {
                ServoLimit::Velocity => 60.0 / (2.0 * PI * 4.0) * (3000.0 / 60.0) / a4,
                ServoLimit::Acceleration => 60.0 / (2.0 * PI * 4.0) * (500.0 / a4).sqrt(),
            };
            assert!((d.speed.largest_c_rpm - expected).abs() <= 1e-12 * expected);
            println!(
                "r {} mm: Z {:.4} to {:.4} mm, A4 {:.4} mm, largest C {:.1} r/min ({limit:?})",
                d.r_mm, d.z_range_mm[0], d.z_range_mm[1], a4, d.speed.largest_c_rpm
            );
        }
        let short = AxisLimits {
            min: Some(0.0),
            max: Some(0.8),
            ..z
        };
        let breach = ring_demands(&layout, &radii, 0.0, 5.0, &short).unwrap_err();
        // The first ring crossing a segment whose fourth harmonic exceeds 0.4 mm: 70 mm.
        assert_eq!((breach.ring, breach.breach.harmonic), (3, 4), "{breach}");
    }
}
