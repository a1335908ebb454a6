//! The motion a dwell plan stands for: Preston's one model of how the tool moves, used by the
//! prediction, the optimizer, the studies and the machine program alike.
//!
//! A plan is positions r_0 < … < r_{n−1} (radial coordinates of surface points, mm) with dwell
//! t_j ≥ 0 (s). Each position owns a **cell** between the midpoints of its neighbours,
//! m_j = (r_j + r_{j+1})/2, and the tool spends exactly t_j there:
//!
//! ```text
//! stop at r_0 for t_0/2;   r_0 → m_0 in t_0/2;   m_{j−1} → m_j in t_j (0 < j < n−1);
//! m_{n−2} → r_{n−1} in t_{n−1}/2;   stop at r_{n−1} for t_{n−1}/2
//! ```
//!
//! (a single position is a stop of t_0). Within a move the tool's speed along the surface is
//! constant: on a curved part a cell of arc length L_j is crossed at L_j/(w_j·t_j), with
//! w_j = ½ for the two end cells and 1 inside (the share of the dwell spent moving). A cell
//! whose dwell is 0 is crossed in no time: it removes nothing, and at either end of the plan
//! the tool simply starts (or ends) at its far boundary; inside a plan a machine cannot do it.
//!
//! So the removal at radius r is
//!
//! ```text
//! ΔZ(r) = Σ_j [ σ_j·t_j·R(r; r_j) + w_j·t_j/L_j · ∫_{cell j} R(r; ρ(s)) ds ]
//! ```
//!
//! with σ_j = ½ for the stops at the two ends (1 for a single position, 0 inside): a linear
//! map of the dwell, whose columns are exact integrals ([`super::path`],
//! [`super::operator`]). A constant feed v from a to b is the same integral without cells:
//! ΔZ(r) = (60/v)·∫_a^b R(r; ρ(s)) ds.
//!
//! # The motion as a value
//!
//! [`Motion`] holds this once per request: the stations (the positions, each a point of the
//! part), their cells, the [`Segment`]s (stops and moves, each spending a share of one
//! station's dwell) and how C turns ([`Turning`]: at the part's constant speed, so the removal
//! is axisymmetric and the 1-D model above is exact; or under a [`SectorLaw`], C's speed set
//! per station and sector, whose removal is 2-D: `super::polar::executed_blocks`). The operator reads its
//! cells and shares ([`super::operator`]), the machine program runs its segments
//! (`machine::Program::from_motion`), and the optimizer's kinematics read the axes' travel
//! across its cells (`optimize::kinematics`); none of them derives the cells again.

/// How the part turns on C while the tool moves.
#[derive(Debug, Clone, PartialEq)]
pub enum Turning {
    /// At the process's part speed throughout (C as a spindle): every angle is swept alike, so
    /// the removal is axisymmetric and a station's angle does not enter it.
    Constant,
    /// C in position control, its speed set per station and per sector of the part
    /// ([`SectorLaw`]): the dwell then varies with the angle as well as the radius.
    Sectors(SectorLaw),
}

/// C's speed law: the part's circle divided into S equal sectors of the pad centre's angle φ
/// in the part's frame (sector k holds φ mod 2π in [2πk/S, 2π(k + 1)/S)), and for each
/// station a factor per sector: when the pad centre enters sector k while station j's dwell
/// is being spent, the part turns at `factor(j, k)` times the process's speed until it leaves
/// the sector (a station that begins within a sector takes over C's speed at the next edge).
/// Factors are positive (C keeps its direction), so the part still turns through every
/// sector; C's speed changes only at sector edges and X's only between stops and moves, each
/// constant in between, which is what a program's blocks in inverse time (G93) execute.
/// A law of factors 1 is C at constant speed.
#[derive(Debug, Clone, PartialEq)]
pub struct SectorLaw {
    sectors: usize,
    /// Station-major: factor(j, k) = factors[j·S + k].
    factors: Vec<f64>,
}

/// The most sectors a law may have: 100,000 (13 arc seconds each), far finer than C is
/// commanded.
pub const MAX_SECTORS: usize = 100_000;

/// Why a C speed law does not fit its motion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SectorLawError {
    #[error("a C speed law needs at least one sector")]
    NoSectors,
    #[error("a C speed law of {0} sectors: at most {MAX_SECTORS}")]
    TooManySectors(usize),
    #[error("{stations} stations of {sectors} sectors need {expected} speed factors, not {got}")]
    Shape {
        stations: usize,
        sectors: usize,
        expected: usize,
        got: usize,
    },
    #[error("station {station}, sector {sector}: a C speed factor must be positive and finite, not {value}")]
    Factor {
        station: usize,
        sector: usize,
        value: f64,
    },
}

impl SectorLaw {
    /// The law of `factors` (station-major, `sectors` per station) for `stations` stations.
    pub fn new(
        stations: usize,
        sectors: usize,
        factors: Vec<f64>,
    ) -> Result<SectorLaw, SectorLawError> {
        Self::check_sectors(sectors)?;
        if factors.len() != stations * sectors {
            return Err(SectorLawError::Shape {
                stations,
                sectors,
                expected: stations * sectors,
                got: factors.len(),
            });
        }
        if let Some(i) = factors.iter().position(|f| !(f.is_finite() && *f > 0.0)) {
            return Err(SectorLawError::Factor {
                station: i / sectors,
                sector: i % sectors,
                value: factors[i],
            });
        }
        Ok(SectorLaw { sectors, factors })
    }

    /// Whether a law may have `sectors` sectors: 1 to [`MAX_SECTORS`].
    pub fn check_sectors(sectors: usize) -> Result<(), SectorLawError> {
        match sectors {
            0 => Err(SectorLawError::NoSectors),
            s if s > MAX_SECTORS => Err(SectorLawError::TooManySectors(s)),
            _ => Ok(()),
        }
    }

    /// S, the sectors per turn.
    pub fn sectors(&self) -> usize {
        self.sectors
    }

    /// The angle of one sector, rad.
    pub fn sector_rad(&self) -> f64 {
        std::f64::consts::TAU / self.sectors as f64
    }

    /// The part's speed over sector k during station j's dwell, as a multiple of the process's.
    pub fn factor(&self, station: usize, sector: usize) -> f64 {
        self.factors[station * self.sectors + sector]
    }
}

/// One piece of a motion: a stop at a station, or a constant-speed move across its cell.
/// Its duration is `share` of the station's dwell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// The pad centre stands at `at_mm`, station `station`'s radius.
    Stop {
        station: usize,
        at_mm: f64,
        share: f64,
    },
    /// The pad centre crosses station `station`'s cell from `from_mm` to `to_mm` at constant
    /// speed along the surface.
    Move {
        station: usize,
        from_mm: f64,
        to_mm: f64,
        share: f64,
    },
}

impl Segment {
    /// The station whose dwell this segment spends.
    pub fn station(&self) -> usize {
        match *self {
            Segment::Stop { station, .. } | Segment::Move { station, .. } => station,
        }
    }

    /// The share of that station's dwell it takes.
    pub fn share(&self) -> f64 {
        match *self {
            Segment::Stop { share, .. } | Segment::Move { share, .. } => share,
        }
    }

    /// Where the pad centre is at the segment's start and end, mm.
    pub fn ends_mm(&self) -> (f64, f64) {
        match *self {
            Segment::Stop { at_mm, .. } => (at_mm, at_mm),
            Segment::Move { from_mm, to_mm, .. } => (from_mm, to_mm),
        }
    }
}

/// The motion of a plan: its stations (radii r_j of the pad centre, mm, strictly increasing),
/// their cells, the stops and moves the dwell is spent in (module docs), and how C turns.
/// Linear in the dwell: the same motion stands for every dwell at its stations, so a request
/// builds it once and the operator, the program and the optimizer's kinematics all read it.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    radii_mm: Vec<f64>,
    /// r_0, the midpoints m_0 … m_{n−2}, r_{n−1} (n + 1 entries for n ≥ 2 stations; the
    /// single station of a one-station plan).
    bounds_mm: Vec<f64>,
    turning: Turning,
}

impl Motion {
    /// The motion through radial stations `radii_mm` (finite and strictly increasing: the
    /// caller checks, [`super::check_positions`]) with C turning at a constant speed.
    pub fn radial(radii_mm: Vec<f64>) -> Motion {
        debug_assert!(radii_mm.windows(2).all(|w| w[0] < w[1]));
        let n = radii_mm.len();
        let bounds_mm = if n < 2 {
            radii_mm.clone()
        } else {
            let mut ends = Vec::with_capacity(n + 1);
            ends.push(radii_mm[0]);
            ends.extend(radii_mm.windows(2).map(|w| 0.5 * (w[0] + w[1])));
            ends.push(radii_mm[n - 1]);
            ends
        };
        Motion {
            radii_mm,
            bounds_mm,
            turning: Turning::Constant,
        }
    }

    /// The number of stations.
    pub fn len(&self) -> usize {
        self.radii_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.radii_mm.is_empty()
    }

    /// The stations' radii r_j, mm.
    pub fn radii_mm(&self) -> &[f64] {
        &self.radii_mm
    }

    /// Where each station's cell begins and ends: r_0, the midpoints, r_{n−1} (one entry for
    /// a single station).
    pub fn cell_bounds_mm(&self) -> &[f64] {
        &self.bounds_mm
    }

    pub fn turning(&self) -> &Turning {
        &self.turning
    }

    /// This motion with C turning by `law` (one factor per sector for each of its stations).
    pub fn with_sector_law(self, law: SectorLaw) -> Result<Motion, SectorLawError> {
        let stations = law.factors.len() / law.sectors;
        if stations != self.len() {
            return Err(SectorLawError::Shape {
                stations: self.len(),
                sectors: law.sectors,
                expected: self.len() * law.sectors,
                got: law.factors.len(),
            });
        }
        Ok(Motion {
            turning: Turning::Sectors(law),
            ..self
        })
    }

    /// w_j: the share of station j's dwell spent moving across its cell (½ at either end of a
    /// plan of n ≥ 2 stations, 1 inside, 0 for a single station).
    pub fn move_share(&self, j: usize) -> f64 {
        let n = self.len();
        if n < 2 {
            0.0
        } else if j == 0 || j == n - 1 {
            0.5
        } else {
            1.0
        }
    }

    /// σ_j: the share of station j's dwell spent standing at it (½ at either end of a plan of
    /// n ≥ 2 stations, 0 inside, 1 for a single station).
    pub fn stop_share(&self, j: usize) -> f64 {
        // Every second of t_j is either spent moving across the cell or standing at r_j.
        1.0 - self.move_share(j)
    }

    /// The segments in the order the tool runs them: a single station's stop; or the stop at
    /// r_0, the move across each cell, the stop at r_{n−1}.
    pub fn segments(&self) -> Vec<Segment> {
        let n = self.len();
        let stop = |station: usize| Segment::Stop {
            station,
            at_mm: self.radii_mm[station],
            share: self.stop_share(station),
        };
        if n < 2 {
            return (0..n).map(stop).collect();
        }
        let moves = (0..n).map(|j| Segment::Move {
            station: j,
            from_mm: self.bounds_mm[j],
            to_mm: self.bounds_mm[j + 1],
            share: self.move_share(j),
        });
        std::iter::once(stop(0))
            .chain(moves)
            .chain(std::iter::once(stop(n - 1)))
            .collect()
    }
}

/// The acceleration model of every axis: its velocity is constant within a segment (a block
/// of a program, a cell of a plan) and changes between consecutive segments over the time
/// between their midpoints, so a change `dv` between segments lasting `before` and `after`
/// (a stop's velocity is 0: a plan's first move starts from its half-dwell stop, t_0/2 each;
/// a program is at rest before its first block and after its last, segments of 0 s) takes
///
/// ```text
/// a = dv / ((d_before + d_after) / 2)
/// ```
///
/// The program reports it ([`crate::machine`]) and the optimizer keeps it within the limits
/// (`optimize::kinematics`).
pub fn acceleration(dv: f64, before_s: f64, after_s: f64) -> f64 {
    dv / (0.5 * (before_s + after_s))
}

/// Whether two speeds are one for the acceleration model: equal to 1e-9 of the larger. A
/// speed law's factors can differ in their last bits where the same bound shaped them (two
/// sectors at the modulation's cap); a drive cannot tell them apart, and splitting its span
/// there would put a change of nothing over a short span.
pub fn one_speed(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shares_account_for_every_second() {
        for n in 1..6 {
            let motion = Motion::radial((0..n).map(|j| j as f64).collect());
            for j in 0..n {
                let (w, s) = (motion.move_share(j), motion.stop_share(j));
                assert_eq!(w + s, 1.0);
                assert!(w >= 0.0 && s >= 0.0);
            }
            // Every station's dwell is spent exactly once over the segments.
            let mut spent = vec![0.0; n];
            for segment in motion.segments() {
                spent[segment.station()] += segment.share();
            }
            assert!(spent.iter().all(|&s| s == 1.0), "{spent:?}");
        }
        let one = Motion::radial(vec![2.0]);
        assert_eq!((one.move_share(0), one.stop_share(0)), (0.0, 1.0));
        let three = Motion::radial(vec![0.0, 1.0, 3.0]);
        assert_eq!((three.move_share(0), three.stop_share(0)), (0.5, 0.5));
        assert_eq!((three.move_share(1), three.stop_share(1)), (1.0, 0.0));
        assert_eq!(three.cell_bounds_mm(), [0.0, 0.5, 2.0, 3.0]);
        let ends: Vec<_> = three.segments().iter().map(Segment::ends_mm).collect();
        assert_eq!(
            ends,
            [(0.0, 0.0), (0.0, 0.5), (0.5, 2.0), (2.0, 3.0), (3.0, 3.0)]
        );
    }
}
