//! Sampled fields: values on a domain — a radial profile, or a polar grid over a round part —
//! with the weights that say how much of the part each sample stands for, and the one
//! interpolator between radial samples.
//!
//! **Area weights.** On radii r_0 < … < r_{n−1} standing for a round part, sample i stands for
//! the annulus between the midpoints to its neighbours (at the ends, r_0 and r_{n−1}
//! themselves):
//!
//! ```text
//! w_i = π·(b_{i+1}² − b_i²),   b_0 = r_0,  b_i = (r_{i−1} + r_i)/2,  b_n = r_{n−1}
//! ```
//!
//! (≈ 2π·r_i·Δr_i; the weights sum to π·(r_{n−1}² − r_0²) exactly). On a polar grid — those
//! radii, and m angles evenly spaced over a full turn — sample (i, j) stands for the sector
//! w_i / m of that annulus. So an axisymmetric map on a polar grid and its radial profile have
//! the same area-weighted figures, to rounding. **Per sample** weights are all 1: each sample
//! counts once (the radial metrics the API has always reported). A weight of 0 masks a sample.
//!
//! **Weighted figures** of values z_k with weights w_k (Σ w > 0):
//!
//! ```text
//! mean = Σ w·z / Σ w     rms = √(Σ w·(z − mean)² / Σ w)     min, max, pv over w > 0
//! ```
//!
//! **Interpolation** between radial samples is linear: at r in [r_k, r_{k+1}],
//! z = z_k + t·(z_{k+1} − z_k) with t = (r − r_k)/(r_{k+1} − r_k); none outside [r_0, r_{n−1}].

/// A radial depth profile as given (unchecked): radii, mm, and the depth at each, nm. It
/// becomes a [`Field`] where it is checked ([`Field::radial`]), in its user's words.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DepthProfile {
    pub radius_mm: Vec<f64>,
    pub depth_nm: Vec<f64>,
}

/// Where a field's samples lie.
#[derive(Debug, Clone, PartialEq)]
pub enum Domain {
    /// Radii, mm (strictly increasing, ≥ 0): a profile of a round part.
    Radial { radius_mm: Vec<f64> },
    /// Radii as above × `angles` angles evenly spaced over a full turn; values radius-major
    /// (the sample at radius i and angle j is value i·angles + j).
    Polar { radius_mm: Vec<f64>, angles: usize },
}

/// Values on a domain, checked once ([`Field::radial`], [`Field::polar`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    domain: Domain,
    values: Vec<f64>,
}

/// How much each sample counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weighting {
    /// Every sample once.
    PerSample,
    /// The area of the part it stands for (see the module docs).
    Area,
}

/// Why samples do not make a field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FieldError {
    #[error("a profile needs at least 2 points")]
    TooFewPoints,
    #[error("{values} values for {samples} samples: they must match")]
    LengthMismatch { values: usize, samples: usize },
    #[error("radius {index} must be a finite number ≥ 0 mm")]
    BadRadius { index: usize },
    #[error("the radii must be strictly increasing; radius {index} is not above the one before")]
    NotIncreasing { index: usize },
    #[error("value {index} must be a finite number")]
    BadValue { index: usize },
    #[error("a polar grid needs at least one angle")]
    NoAngles,
    #[error("a polar grid has no single value per radius to interpolate")]
    NotRadial,
    #[error("the field spans [{lo}, {hi}] mm but the radii asked for span [{first}, {last}] mm")]
    NotCovering {
        lo: f64,
        hi: f64,
        first: f64,
        last: f64,
    },
}

fn check_radii(radius_mm: &[f64]) -> Result<(), FieldError> {
    if radius_mm.len() < 2 {
        return Err(FieldError::TooFewPoints);
    }
    for (index, &r) in radius_mm.iter().enumerate() {
        if !r.is_finite() || r < 0.0 {
            return Err(FieldError::BadRadius { index });
        }
        if index > 0 && r <= radius_mm[index - 1] {
            return Err(FieldError::NotIncreasing { index });
        }
    }
    Ok(())
}

fn check_values(values: &[f64], samples: usize) -> Result<(), FieldError> {
    if values.len() != samples {
        return Err(FieldError::LengthMismatch {
            values: values.len(),
            samples,
        });
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(FieldError::BadValue { index }),
        None => Ok(()),
    }
}

impl Field {
    /// A radial profile: `values[i]` at `radius_mm[i]` (at least 2, strictly increasing, ≥ 0).
    pub fn radial(radius_mm: Vec<f64>, values: Vec<f64>) -> Result<Field, FieldError> {
        check_radii(&radius_mm)?;
        check_values(&values, radius_mm.len())?;
        Ok(Field {
            domain: Domain::Radial { radius_mm },
            values,
        })
    }

    /// A polar grid: radii as [`Field::radial`] × `angles` (≥ 1) angles over a full turn,
    /// values radius-major.
    pub fn polar(
        radius_mm: Vec<f64>,
        angles: usize,
        values: Vec<f64>,
    ) -> Result<Field, FieldError> {
        check_radii(&radius_mm)?;
        if angles == 0 {
            return Err(FieldError::NoAngles);
        }
        check_values(&values, radius_mm.len() * angles)?;
        Ok(Field {
            domain: Domain::Polar { radius_mm, angles },
            values,
        })
    }

    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The domain's radii, mm.
    pub fn radius_mm(&self) -> &[f64] {
        match &self.domain {
            Domain::Radial { radius_mm } | Domain::Polar { radius_mm, .. } => radius_mm,
        }
    }

    /// The radial field's value at `r` by linear interpolation; `None` outside its span or on
    /// a polar grid (which has no single value per radius).
    pub fn at(&self, r: f64) -> Option<f64> {
        let Domain::Radial { radius_mm } = &self.domain else {
            return None;
        };
        interpolate_within(radius_mm, &self.values, r)
    }

    /// The radial field at each of `radii_mm` (ascending, within its span).
    pub fn resample(&self, radii_mm: &[f64]) -> Result<Vec<f64>, FieldError> {
        let Domain::Radial { radius_mm } = &self.domain else {
            return Err(FieldError::NotRadial);
        };
        let (lo, hi) = (radius_mm[0], radius_mm[radius_mm.len() - 1]);
        if let (Some(&first), Some(&last)) = (radii_mm.first(), radii_mm.last()) {
            if first < lo || last > hi {
                return Err(FieldError::NotCovering {
                    lo,
                    hi,
                    first,
                    last,
                });
            }
        }
        Ok(radii_mm
            .iter()
            .map(|&r| interpolate(radius_mm, &self.values, r))
            .collect())
    }

    /// Each sample's weight (see the module docs), in the order of [`Field::values`].
    pub fn weights(&self, weighting: Weighting) -> Vec<f64> {
        if weighting == Weighting::PerSample {
            return vec![1.0; self.values.len()];
        }
        match &self.domain {
            Domain::Radial { radius_mm } => annulus_areas(radius_mm),
            Domain::Polar { radius_mm, angles } => annulus_areas(radius_mm)
                .into_iter()
                .flat_map(|w| std::iter::repeat_n(w / *angles as f64, *angles))
                .collect(),
        }
    }

    /// The weighted figures of the field's values, samples with weight 0 left out; `None`
    /// when every weight is 0.
    pub fn figures(&self, weighting: Weighting) -> Option<Figures> {
        Figures::weighted(&self.values, &self.weights(weighting))
    }
}

/// Linear interpolation of `values` on ascending `radius_mm` at `r` within their span.
/// The one interpolator on radial samples as slices (`radius_mm` strictly increasing, one
/// value each): the value at `r` within their span, `None` outside it (a single sample spans
/// its own radius).
pub fn interpolate_within(radius_mm: &[f64], values: &[f64], r: f64) -> Option<f64> {
    let (&lo, &hi) = (radius_mm.first()?, radius_mm.last()?);
    if !(lo..=hi).contains(&r) {
        return None;
    }
    if radius_mm.len() == 1 {
        return Some(values[0]);
    }
    Some(interpolate(radius_mm, values, r))
}

fn interpolate(radius_mm: &[f64], values: &[f64], r: f64) -> f64 {
    // The segment [radius_mm[k], radius_mm[k+1]] holding r.
    let k = radius_mm
        .partition_point(|&x| x <= r)
        .clamp(1, radius_mm.len() - 1)
        - 1;
    let (r0, r1) = (radius_mm[k], radius_mm[k + 1]);
    let t = (r - r0) / (r1 - r0);
    values[k] + t * (values[k + 1] - values[k])
}

/// The area of the annulus each radius stands for (see the module docs), mm².
fn annulus_areas(radius_mm: &[f64]) -> Vec<f64> {
    let n = radius_mm.len();
    let bound = |i: usize| match i {
        0 => radius_mm[0],
        i if i == n => radius_mm[n - 1],
        i => 0.5 * (radius_mm[i - 1] + radius_mm[i]),
    };
    (0..n)
        .map(|i| std::f64::consts::PI * (bound(i + 1).powi(2) - bound(i).powi(2)))
        .collect()
}

/// Weighted figures of sampled values (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Figures {
    pub mean: f64,
    pub min: f64,
    pub max: f64,
    pub pv: f64,
    pub rms: f64,
    /// Samples with a weight above 0.
    pub samples: usize,
}

impl Figures {
    /// The figures of `values` with `weights` (one each, ≥ 0); `None` when no weight is above 0.
    pub fn weighted(values: &[f64], weights: &[f64]) -> Option<Figures> {
        assert_eq!(values.len(), weights.len());
        Self::of(values.iter().copied().zip(weights.iter().copied()))
    }

    /// The figures of `values`, each counting once; `None` when there are none.
    pub fn unweighted(values: &[f64]) -> Option<Figures> {
        Self::of(values.iter().map(|&z| (z, 1.0)))
    }

    /// The figures of (value, weight) pairs: the sums in one pass, the RMS about the mean in a
    /// second.
    fn of(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> Option<Figures> {
        let counted = pairs.filter(|&(_, w)| w > 0.0);
        // -0.0: the neutral element `Iterator::sum` starts from, so an all −0 sum stays −0.
        let (mut total, mut sum, mut min, mut max, mut samples) =
            (-0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY, 0);
        for (z, w) in counted.clone() {
            total += w;
            sum += w * z;
            (min, max) = (min.min(z), max.max(z));
            samples += 1;
        }
        if total <= 0.0 {
            return None;
        }
        let mean = sum / total;
        let rms = (counted.map(|(z, w)| w * (z - mean).powi(2)).sum::<f64>() / total).sqrt();
        Some(Figures {
            mean,
            min,
            max,
            pv: max - min,
            rms,
            samples,
        })
    }
}

/// Figures gathered one value at a time, in one pass: count, min, max and the sums of
/// d = z − c and d² about a shift c (the first value, or any close to the mean), so that
/// mean = c + Σd/n and rms² = Σd²/n − (Σd/n)² lose nothing to cancellation unless the mean
/// lies many RMS from c. Tallies of parts of the values merge (they must share c).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tally {
    shift: f64,
    count: usize,
    sum: f64,
    squares: f64,
    min: f64,
    max: f64,
}

impl Tally {
    /// An empty tally about `shift`.
    pub fn new(shift: f64) -> Tally {
        Tally {
            shift,
            count: 0,
            sum: 0.0,
            squares: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }

    #[inline]
    pub fn push(&mut self, z: f64) {
        let d = z - self.shift;
        self.count += 1;
        self.sum += d;
        self.squares += d * d;
        self.min = self.min.min(z);
        self.max = self.max.max(z);
    }

    /// Adds another part's tally (about the same shift).
    pub fn merge(&mut self, other: &Tally) {
        debug_assert_eq!(self.shift.to_bits(), other.shift.to_bits());
        self.count += other.count;
        self.sum += other.sum;
        self.squares += other.squares;
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// The figures (all 0 for an empty tally).
    pub fn figures(&self) -> Figures {
        if self.count == 0 {
            return Figures {
                mean: 0.0,
                min: 0.0,
                max: 0.0,
                pv: 0.0,
                rms: 0.0,
                samples: 0,
            };
        }
        let n = self.count as f64;
        let offset = self.sum / n;
        Figures {
            mean: self.shift + offset,
            min: self.min,
            max: self.max,
            pv: self.max - self.min,
            rms: (self.squares / n - offset * offset).max(0.0).sqrt(),
            samples: self.count,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_linearly_within_the_span_only() {
        let f = Field::radial(vec![0.0, 10.0, 30.0], vec![1.0, 3.0, -1.0]).unwrap();
        assert_eq!(f.at(5.0), Some(2.0));
        assert_eq!(f.at(20.0), Some(1.0));
        assert_eq!(f.at(30.0), Some(-1.0));
        assert_eq!(f.at(30.5), None);
        assert_eq!(
            f.resample(&[0.0, 10.0, 30.0]).unwrap(),
            vec![1.0, 3.0, -1.0]
        );
        assert!(matches!(
            f.resample(&[-1.0]),
            Err(FieldError::NotCovering { .. })
        ));
    }

    #[test]
    fn refuses_what_is_not_a_field() {
        let e = |r: Vec<f64>, v: Vec<f64>| Field::radial(r, v).unwrap_err();
        assert_eq!(e(vec![1.0], vec![0.0]), FieldError::TooFewPoints);
        assert_eq!(
            e(vec![1.0, 1.0], vec![0.0, 0.0]),
            FieldError::NotIncreasing { index: 1 }
        );
        assert_eq!(
            e(vec![-1.0, 1.0], vec![0.0, 0.0]),
            FieldError::BadRadius { index: 0 }
        );
        assert_eq!(
            e(vec![0.0, 1.0], vec![0.0, f64::NAN]),
            FieldError::BadValue { index: 1 }
        );
        assert_eq!(
            e(vec![0.0, 1.0], vec![0.0]),
            FieldError::LengthMismatch {
                values: 1,
                samples: 2
            }
        );
        assert_eq!(
            Field::polar(vec![0.0, 1.0], 0, vec![]).unwrap_err(),
            FieldError::NoAngles
        );
    }

    /// Area weights cover the disc exactly: Σ w = π·R² from r = 0.
    #[test]
    fn area_weights_sum_to_the_area() {
        let r: Vec<f64> = (0..=50).map(|k| f64::from(k) * 0.8).collect();
        let f = Field::radial(r, vec![0.0; 51]).unwrap();
        let total: f64 = f.weights(Weighting::Area).iter().sum();
        assert!((total / (std::f64::consts::PI * 40.0 * 40.0) - 1.0).abs() < 1e-14);
    }

    /// An axisymmetric map on a polar grid and its radial profile: the same area-weighted RMS
    /// and mean (to 1e-9 relative; they agree to rounding), while the per-sample figures of
    /// the profile (each radius once) are another thing.
    #[test]
    fn an_axisymmetric_map_and_its_profile_agree_by_area() {
        let radius: Vec<f64> = (0..=120)
            .map(|k| 50.0 * (f64::from(k) / 120.0).powf(0.8))
            .collect();
        let profile_of = |r: f64| 30.0 * (r / 50.0).powi(2) - 12.0 * (r / 9.0).cos() + 4.0;
        let values: Vec<f64> = radius.iter().map(|&r| profile_of(r)).collect();
        let angles = 72;
        let map: Vec<f64> = values
            .iter()
            .flat_map(|&z| std::iter::repeat_n(z, angles))
            .collect();
        let profile = Field::radial(radius.clone(), values).unwrap();
        let grid = Field::polar(radius, angles, map).unwrap();
        let (p, g) = (
            profile.figures(Weighting::Area).unwrap(),
            grid.figures(Weighting::Area).unwrap(),
        );
        assert!((p.rms / g.rms - 1.0).abs() < 1e-9, "{} vs {}", p.rms, g.rms);
        assert!(
            (p.mean / g.mean - 1.0).abs() < 1e-9,
            "{} vs {}",
            p.mean,
            g.mean
        );
        assert_eq!((p.min, p.max), (g.min, g.max));
        let per_sample = profile.figures(Weighting::PerSample).unwrap();
        assert!(
            (per_sample.rms / p.rms - 1.0).abs() > 1e-3,
            "the weights matter here"
        );
    }

    #[test]
    fn zero_weights_mask_samples() {
        let f = Figures::weighted(&[1.0, 100.0, 3.0], &[1.0, 0.0, 1.0]).unwrap();
        assert_eq!((f.mean, f.min, f.max, f.samples), (2.0, 1.0, 3.0, 2));
        assert_eq!(Figures::weighted(&[1.0], &[0.0]), None);
    }
}
