//! The η = −1 recommendation as a use case, and the [`Recommender`] that serves it from
//! bounded caches.
//!
//! A recommendation needs equal dwell at the user's speeds, equal dwell at η = −1, and the η
//! window (a few dozen more equal-dwell passes: outward steps and regula falsi on the
//! equal-dwell nonuniformity N(η)). Only the first depends on the user's speeds; the η = −1
//! pass and the window depend on the geometry, pressure model, grid, aperture, pass and
//! threshold alone (removal at η = −1 is linear in speed·K·P, and N(η) is scale-free in them:
//! see [`crate::study::GeometryParts`]). So those are cached on that key, and every process of
//! one machine set-up shares them. The pass at the user's speeds is read from each radius's
//! running integral ([`crate::study::current_pass`]); a prediction or an optimization that has
//! just assembled its operator hands over what the operator's rows read of it
//! ([`crate::study::pass_reading`]), the same bits, so a new process costs no pass of its own.
//! Whole recommendations (per unit depth; plans scale with the depth) are cached on every
//! input as well, for callers that ask about the same process again and again.
//!
//! Every cache is bounded (emptied when full) and deterministic: what it holds is a function
//! of the key alone, so a response never depends on what was asked before.

use std::collections::HashMap;
use std::hash::Hash;
use std::sync::{Arc, Mutex};

use super::warnings::process_warnings;
use super::{Input, InputError, Setting, Warning};
use crate::machine::MachineLimits;
use crate::optimize::problem::MAX_DEPTH_NM;
use crate::physics::{PassReading, Process};
use crate::study::{
    self, EqualDwell, Frame, GeometryParts, Recommendation, SpeedLimits, StudyError,
};

/// Default η-window threshold on equal-dwell nonuniformity (2 %).
pub const DEFAULT_THRESHOLD: f64 = 0.02;
/// Default depth of the equal-dwell plan, nm.
pub const DEFAULT_DEPTH_NM: f64 = 100.0;
/// Least depth an equal-dwell plan may remove, nm (a femtometre): the feed grows as the depth
/// shrinks, and below this it can overflow.
pub const MIN_DEPTH_NM: f64 = 1e-6;
/// Entries each cache holds before it is emptied.
const CACHE_CAPACITY: usize = 256;

/// A recommendation for the user's process within the machine's speed limits.
#[derive(Debug, Clone, PartialEq)]
pub struct RecommendCommand {
    setting: Setting,
    limits: SpeedLimits,
    depth_nm: f64,
    threshold: f64,
}

impl RecommendCommand {
    /// `depth_nm` (default 100) in [1e-6, 1e9] nm; `threshold` (default 0.02) a finite fraction
    /// > 0.
    pub fn new(
        setting: Setting,
        limits: SpeedLimits,
        depth_nm: Option<f64>,
        threshold: Option<f64>,
    ) -> Result<Self, InputError> {
        let depth_nm = equal_dwell_depth(depth_nm)?;
        let threshold = threshold.unwrap_or(DEFAULT_THRESHOLD);
        if !threshold.is_finite() || threshold <= 0.0 {
            return Err(InputError::OutOfRange {
                input: Input::NonuniformityThreshold,
                max: f64::MAX,
            });
        }
        Ok(RecommendCommand {
            setting,
            limits,
            depth_nm,
            threshold,
        })
    }

    pub fn setting(&self) -> &Setting {
        &self.setting
    }
}

/// The depth of an equal-dwell plan: `None` means [`DEFAULT_DEPTH_NM`]; in
/// [[`MIN_DEPTH_NM`], 1e9] nm.
pub(super) fn equal_dwell_depth(depth_nm: Option<f64>) -> Result<f64, InputError> {
    let depth = depth_nm.unwrap_or(DEFAULT_DEPTH_NM);
    if (MIN_DEPTH_NM..=MAX_DEPTH_NM).contains(&depth) {
        Ok(depth)
    } else {
        Err(InputError::OutOfRange {
            input: Input::Depth,
            max: MAX_DEPTH_NM,
        })
    }
}

/// A recommendation and what the caller should know about the input it was made for.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommended {
    pub recommendation: Recommendation,
    /// Likely unit mistakes in the process.
    pub warnings: Vec<Warning>,
}

/// Recommends η = −1 speeds (see [`crate::study::recommend`]).
pub fn recommend(
    command: &RecommendCommand,
    recommender: &Recommender,
) -> Result<Recommended, StudyError> {
    let RecommendCommand {
        setting,
        limits,
        depth_nm,
        threshold,
    } = command;
    let recommendation = recommender.recommendation(
        setting.process(),
        setting.frame(),
        *limits,
        *depth_nm,
        *threshold,
        None,
    )?;
    Ok(Recommended {
        recommendation,
        warnings: process_warnings(setting.process()),
    })
}

/// A map that empties itself when it reaches its capacity.
#[derive(Debug)]
struct BoundedCache<K, V> {
    entries: Mutex<HashMap<K, V>>,
    capacity: usize,
}

impl<K: Eq + Hash, V: Clone> BoundedCache<K, V> {
    fn new(capacity: usize) -> Self {
        BoundedCache {
            entries: Mutex::new(HashMap::new()),
            capacity,
        }
    }

    /// The value for `key`, computed by `make` (outside the lock) when absent. Values `make`
    /// refuses are not kept.
    fn get_or_try<E>(&self, key: K, make: impl FnOnce() -> Result<V, E>) -> Result<V, E> {
        if let Some(v) = self.entries.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return Ok(v);
        }
        let value = make()?;
        if let Ok(mut c) = self.entries.lock() {
            if c.len() >= self.capacity {
                c.clear();
            }
            c.insert(key, value.clone());
        }
        Ok(value)
    }
}

/// Serves recommendations; one per service, shared by every request.
#[derive(Debug)]
pub struct Recommender {
    /// Whole recommendations per unit depth, keyed by every input.
    recommendations: BoundedCache<Vec<u64>, Arc<Recommendation>>,
    /// The geometry-only parts (η = −1 pass, η window), keyed by what they depend on.
    geometry: BoundedCache<Vec<u64>, Arc<GeometryParts>>,
    /// Equal dwell per unit depth at the user's speeds, keyed by the geometry, speeds, K and P.
    current: BoundedCache<Vec<u64>, Arc<EqualDwell>>,
}

impl Default for Recommender {
    fn default() -> Self {
        Recommender {
            recommendations: BoundedCache::new(CACHE_CAPACITY),
            geometry: BoundedCache::new(CACHE_CAPACITY),
            current: BoundedCache::new(CACHE_CAPACITY),
        }
    }
}

/// The bits of the geometry and the frame: what an equal-dwell pass depends on besides the
/// speeds, K and P.
fn frame_key(process: &Process, frame: Frame) -> Vec<u64> {
    let s = process.spec();
    let mut key: Vec<u64> = [
        s.workpiece_radius_mm,
        s.tool_radius_mm,
        frame.grid.start_mm(),
        frame.grid.stop_mm(),
        frame.aperture.inner_mm(),
        frame.aperture.outer_mm(),
    ]
    .iter()
    .map(|v| v.to_bits())
    .collect();
    key.extend([
        frame.grid.radii_mm().len() as u64,
        s.part.orientation as u64,
    ]);
    key.extend(s.pressure_model.key_bits());
    key.extend(s.part.surface.key_bits());
    key
}

fn bits(values: &[f64]) -> impl Iterator<Item = u64> + '_ {
    values.iter().map(|v| v.to_bits())
}

impl Recommender {
    pub fn new() -> Self {
        Self::default()
    }

    /// The recommendation for these inputs at `depth_nm` (> 0), from the caches when possible;
    /// `read` is the pass at the user's speeds as an operator read it beside its rows
    /// ([`study::pass_reading`]) when one was just assembled (the same bits as reading it
    /// alone, without the work), else `None`.
    pub fn recommendation(
        &self,
        process: &Process,
        frame: Frame,
        limits: SpeedLimits,
        depth_nm: f64,
        threshold: f64,
        read: Option<Vec<f64>>,
    ) -> Result<Recommendation, StudyError> {
        let s = process.spec();
        let frame_key = frame_key(process, frame);
        let mut at_process = frame_key.clone();
        at_process.extend(bits(&[
            s.workpiece_rpm,
            s.tool_rpm,
            s.preston_coefficient_m2_per_n,
            s.pressure_kpa,
        ]));
        let mut key = at_process.clone();
        key.extend(bits(&[
            threshold,
            limits.max_workpiece_rpm().unwrap_or(-1.0),
            limits.max_tool_rpm().unwrap_or(-1.0),
        ]));
        let unit = self.recommendations.get_or_try(key, || {
            let mut geometry = frame_key.clone();
            geometry.extend(bits(&[threshold]));
            let parts = self.geometry.get_or_try(geometry, || {
                GeometryParts::new(process, frame, threshold).map(Arc::new)
            })?;
            let current = self.current.get_or_try(at_process, || {
                study::current_pass(process, frame, read).map(Arc::new)
            })?;
            study::recommend(process, limits, 1.0, &parts, &current).map(Arc::new)
        })?;
        Ok(unit.scaled_to(depth_nm))
    }

    /// The pass a plan's operator reads beside its rows for [`Self::for_plan`] when it is
    /// assembled: `None` where the plan carries no recommendation (η = −1).
    pub fn pass_to_read(setting: &Setting) -> Option<PassReading> {
        if setting.process().is_eta_minus_one() {
            return None;
        }
        study::pass_reading(setting.process(), setting.frame())
    }

    /// The recommendation a plan (a prediction or an optimized plan) carries: `None` at
    /// η = −1 or when equal dwell removes nothing in the aperture. Uses the default
    /// threshold and pass, removing the plan's mean depth (the default depth when that is not
    /// a positive number).
    /// `read`: the pass at the user's speeds as the plan's operator read it beside its rows
    /// ([`study::pass_reading`]), when it was assembled for this plan.
    /// `machine`: the spindle limits of the machine the plan is for, which the recommended
    /// speeds keep.
    pub fn for_plan(
        &self,
        setting: &Setting,
        mean_depth_nm: f64,
        read: Option<Vec<f64>>,
        machine: &MachineLimits,
    ) -> Option<Recommendation> {
        if setting.process().is_eta_minus_one() {
            return None;
        }
        let depth = if mean_depth_nm > 0.0 && mean_depth_nm.is_finite() {
            mean_depth_nm
        } else {
            DEFAULT_DEPTH_NM
        };
        let (workpiece, tool) = machine.spindle_max_rpm();
        // Checked limits (finite, > 0) always make speed limits.
        let limits = SpeedLimits::new(workpiece, tool).unwrap_or_default();
        self.recommendation(
            setting.process(),
            setting.frame(),
            limits,
            depth,
            DEFAULT_THRESHOLD,
            read,
        )
        .ok()
        // A depth too small for any finite feed (a denormal one): nothing to recommend.
        .filter(|r| {
            r.current.feed_mm_per_min().is_finite() && r.recommended.feed_mm_per_min().is_finite()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;
    use crate::physics::{
        ClearAperture, Layout, Motion, Orientation, Part, PressureModel, ProcessSpec, RadialGrid,
        RemovalKernel, RemovalOperator, RowReading,
    };
    use crate::surface::{Surface, SurfaceSpec};

    /// The pass an operator reads beside its rows is the pass read alone, bit for bit, so a
    /// recommendation never depends on whether its plan's operator was just assembled or came
    /// from the cache: on a plane under uniform pressure and constant force, and on a sphere.
    /// A linear pad's running integrals depend on the path's end, so its rows read no pass.
    #[test]
    fn a_pass_read_beside_an_operator_is_the_pass_read_alone() {
        let base = paper_spec(-10.0, 200.0);
        let sphere = Part {
            surface: Surface::new(&SurfaceSpec::Sphere {
                radius_of_curvature_mm: -150.0,
            })
            .unwrap(),
            orientation: Orientation::Normal,
        };
        let specs = [
            base.clone(),
            ProcessSpec {
                pressure_model: PressureModel::ConstantForce,
                ..base.clone()
            },
            ProcessSpec {
                part: sphere,
                ..base.clone()
            },
            ProcessSpec {
                pressure_model: PressureModel::Linear {
                    pad_moment_share: 1.0,
                },
                ..base.clone()
            },
        ];
        for spec in specs {
            let process = Process::new(spec.clone()).unwrap();
            let grid = RadialGrid::default_for(&process);
            let aperture = ClearAperture::new(&process, 0.0, 40.0).unwrap();
            let frame = Frame {
                grid: &grid,
                aperture: &aperture,
            };
            let reading = study::pass_reading(&process, frame).unwrap();
            let alone = reading
                .feed
                .removal_read_nm(&process, &grid.radii_mm()[reading.rows.clone()]);
            // Positions over the whole pass; over its first part only, so that the outer rows
            // have no columns (their pass is read from a path made for it alone); one stop.
            let plans = [
                (0..=90).map(|j| 0.5 * j as f64).collect(),
                (0..=40).map(|j| 0.5 * j as f64).collect(),
                vec![12.5],
            ]
            .map(Motion::radial);
            for motion in plans {
                let (_, passed) = RemovalOperator::assemble_reading(
                    &RemovalKernel::new(&process),
                    grid.radii_mm(),
                    &motion,
                    Some(&reading as &dyn RowReading),
                    Layout::Rows,
                );
                if matches!(spec.pressure_model, PressureModel::Linear { .. }) {
                    assert!(passed.is_none());
                    continue;
                }
                let passed = passed.unwrap();
                assert_eq!(passed.len(), 161);
                for (k, (a, b)) in passed.iter().zip(&alone).enumerate() {
                    assert_eq!(a.to_bits(), b.to_bits(), "{spec:?}: row {k}");
                }
                // Read in two stages (the rows of an aperture first, the pass's rows in both
                // stages, or in the second alone): the same bits.
                let n = grid.radii_mm().len();
                for first in [reading.rows.clone(), 50..n, 0..80, 180..n] {
                    let (_, staged, ()) = RemovalOperator::assemble_while(
                        &RemovalKernel::new(&process),
                        grid.radii_mm(),
                        &motion,
                        Some(&reading as &dyn RowReading),
                        first.clone(),
                        |_, _| (),
                    );
                    assert_eq!(staged.as_ref(), Some(&passed), "{spec:?}: first {first:?}");
                }
                let ask = |read| {
                    Recommender::new()
                        .recommendation(&process, frame, SpeedLimits::default(), 100.0, 0.02, read)
                        .unwrap()
                };
                assert_eq!(ask(Some(passed)), ask(None), "{spec:?}");
            }
        }
    }

    /// What one service caches for one process must never answer for another: recommendations
    /// from a shared recommender, asked in turn about processes that share a set-up and η (or
    /// not), equal those of a fresh one; and they scale as the physics says.
    #[test]
    fn cached_parts_never_leak_between_processes() {
        let base = paper_spec(-10.0, 200.0);
        let processes = [
            base.clone(),
            ProcessSpec {
                workpiece_rpm: -30.0,
                tool_rpm: 600.0,
                ..base.clone()
            },
            ProcessSpec {
                pressure_kpa: 20.0,
                ..base.clone()
            },
            ProcessSpec {
                workpiece_rpm: -20.0,
                ..base.clone()
            },
            ProcessSpec {
                tool_rpm: 0.0,
                ..base.clone()
            },
        ]
        .map(|s| Process::new(s).unwrap());
        let grid = RadialGrid::default_for(&processes[0]);
        let aperture = ClearAperture::new(&processes[0], 0.0, 40.0).unwrap();
        let frame = Frame {
            grid: &grid,
            aperture: &aperture,
        };
        let ask = |r: &Recommender, p: &Process| {
            r.recommendation(p, frame, SpeedLimits::default(), 100.0, 0.02, None)
                .unwrap()
        };
        let shared = Recommender::new();
        let answers: Vec<Recommendation> = processes.iter().map(|p| ask(&shared, p)).collect();
        for (p, answer) in processes.iter().zip(&answers) {
            assert_eq!(answer, &ask(&Recommender::new(), p), "{:?}", p.spec());
        }
        // Three times the speeds (same η): three times the recommended speed, a third of the
        // dwell, the same uniformity. Twice the pressure doubles both rates: the same speed,
        // half the time.
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
        assert!(rel(answers[1].tool_rpm, 3.0 * answers[0].tool_rpm) < 1e-12);
        assert!(
            rel(
                answers[1].current.total_time_s,
                answers[0].current.total_time_s / 3.0
            ) < 1e-12
        );
        // Each pass is computed at its own speeds: linear in them to rounding.
        assert!(
            rel(
                answers[1].current.metrics.nonuniformity.unwrap(),
                answers[0].current.metrics.nonuniformity.unwrap()
            ) < 1e-12
        );
        assert!(rel(answers[2].tool_rpm, answers[0].tool_rpm) < 1e-12);
        assert!(
            rel(
                answers[2].recommended.total_time_s,
                answers[0].recommended.total_time_s / 2.0
            ) < 1e-12
        );
        // A different η is a different comparison.
        assert_ne!(
            answers[3].current.metrics.nonuniformity,
            answers[0].current.metrics.nonuniformity
        );
    }
}
