//! A program as G-code, RS274/NGC dialect (LinuxCNC): G21 millimetres, G90 absolute, G93
//! inverse-time feed (default: every polishing move carries F = 1/duration in min⁻¹, so its
//! time is exact whatever the axes do) or G94 (F = the X–Z path feed in mm/min; a move of B
//! alone carries deg/min), G4 P dwells in seconds, G1 for every move in contact. The approach
//! and retract run in G94 at their own feed.
//!
//! An X-Y program ([`write_xy`]) moves X and Y in G93 and Z in G94.
//!
//! A polar program ([`write_polar`]) adds C, the part's spindle under position control, to
//! every block and runs them all in G93, approach and retract included (C turns in each);
//! C's words are wrapped to [0°, 360°) or cumulative ([`CWords`]).
//!
//! **Spindle directions.** Speeds are signed in one lab frame, counter-clockwise positive as
//! seen from the tool side. M3/M4 mean clockwise/counter-clockwise as seen from the spindle
//! looking at its work, so a positive tool speed is counter-clockwise to the tool spindle
//! (its `ccw` word) while a positive workpiece speed is clockwise to the workpiece spindle,
//! which looks from the other side (its `cw` word). The words are configurable; the defaults
//! address the workpiece as spindle 0 (`M3`, `M4`, `M5`) and the tool as spindle 1
//! (`M3 $1`, `M4 $1`, `M5 $1`).

use std::fmt::Write;

use super::polar_program::PolarProgram;
use super::pose::Pose;
use super::program::{BlockKind, Program};
use super::xy_program::XyProgram;

/// How polishing moves carry their feed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedMode {
    /// G93: F = 1/duration (min⁻¹).
    InverseTime,
    /// G94: F in mm/min along the X–Z path.
    UnitsPerMinute,
}

/// The words that turn one spindle clockwise, counter-clockwise (as seen from that spindle
/// looking at its work) and stop it. The speed follows as `S<|rpm|>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpindleWords {
    pub cw: String,
    pub ccw: String,
    pub stop: String,
}

impl SpindleWords {
    pub fn workpiece_default() -> Self {
        SpindleWords {
            cw: "M3".into(),
            ccw: "M4".into(),
            stop: "M5".into(),
        }
    }

    pub fn tool_default() -> Self {
        SpindleWords {
            cw: "M3 $1".into(),
            ccw: "M4 $1".into(),
            stop: "M5 $1".into(),
        }
    }
}

/// How the G-code is to be written, as a caller gives it: each member optional (default
/// inverse time, 4 decimals, LinuxCNC's spindle words). Unchecked: see [`GcodeFormat::new`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GcodeFormatSpec {
    pub feed_mode: Option<FeedMode>,
    /// Decimals of X, Z (mm) and B (deg).
    pub decimals: Option<u32>,
    pub workpiece_spindle: SpindleWordsSpec,
    pub tool_spindle: SpindleWordsSpec,
}

/// One spindle's words as given; each defaults to the spindle's own.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SpindleWordsSpec {
    pub cw: Option<String>,
    pub ccw: Option<String>,
    pub stop: Option<String>,
}

impl SpindleWordsSpec {
    fn or(self, default: SpindleWords) -> SpindleWords {
        SpindleWords {
            cw: self.cw.unwrap_or(default.cw),
            ccw: self.ccw.unwrap_or(default.ccw),
            stop: self.stop.unwrap_or(default.stop),
        }
    }
}

/// How the G-code is written: defaults filled, every word safe to write
/// ([`GcodeFormat::new`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GcodeFormat {
    feed_mode: FeedMode,
    /// Decimals of X, Z (mm) and B (deg).
    decimals: u32,
    workpiece_spindle: SpindleWords,
    tool_spindle: SpindleWords,
}

/// Most decimals of a coordinate (0.1 nm).
pub const MAX_DECIMALS: u32 = 7;
/// Decimals of a dwell time, s.
const TIME_DECIMALS: usize = 6;
/// Significant digits of an inverse-time feed.
const FEED_DIGITS: i32 = 10;

/// A format that could not be written safely.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GcodeFormatError {
    #[error("decimals must be from 0 to {MAX_DECIMALS}")]
    Decimals,
    /// `spindle` is `workpiece_spindle` or `tool_spindle`, `word` is `cw`, `ccw` or `stop`.
    #[error(
        "{spindle}.{word} must be 1 to 32 printable ASCII characters without parentheses or \
         semicolons (they would start a comment)"
    )]
    Word {
        spindle: &'static str,
        word: &'static str,
    },
}

impl GcodeFormat {
    /// The format of `spec`, its defaults filled and checked.
    pub fn new(spec: GcodeFormatSpec) -> Result<GcodeFormat, GcodeFormatError> {
        let format = GcodeFormat {
            feed_mode: spec.feed_mode.unwrap_or(FeedMode::InverseTime),
            decimals: spec.decimals.unwrap_or(4),
            workpiece_spindle: spec.workpiece_spindle.or(SpindleWords::workpiece_default()),
            tool_spindle: spec.tool_spindle.or(SpindleWords::tool_default()),
        };
        format.check()?;
        Ok(format)
    }

    fn check(&self) -> Result<(), GcodeFormatError> {
        if self.decimals > MAX_DECIMALS {
            return Err(GcodeFormatError::Decimals);
        }
        for (spindle, words) in [
            ("workpiece_spindle", &self.workpiece_spindle),
            ("tool_spindle", &self.tool_spindle),
        ] {
            for (word, text) in [
                ("cw", &words.cw),
                ("ccw", &words.ccw),
                ("stop", &words.stop),
            ] {
                let fine = (1..=32).contains(&text.len())
                    && text
                        .chars()
                        .all(|c| (' '..='~').contains(&c) && !"();".contains(c));
                if !fine || text.trim().is_empty() {
                    return Err(GcodeFormatError::Word { spindle, word });
                }
            }
        }
        Ok(())
    }
}

/// `value` with `decimals` decimals, never as `-0`.
fn fixed(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// `value` (> 0) with `FEED_DIGITS` significant digits, no exponent.
fn significant(value: f64) -> String {
    let magnitude = value.abs().log10().floor() as i32;
    fixed(value, (FEED_DIGITS - 1 - magnitude).max(0) as usize)
}

/// A comment line: parentheses inside would end it early.
fn comment(text: &str) -> String {
    let clean: String = text
        .chars()
        .map(|c| {
            if "()".contains(c) || c.is_control() {
                ' '
            } else {
                c
            }
        })
        .collect();
    format!("({clean})")
}

fn spindle_on(words: &SpindleWords, rpm: f64, clockwise_when_positive: bool) -> String {
    if rpm == 0.0 {
        return words.stop.clone();
    }
    let clockwise = (rpm > 0.0) == clockwise_when_positive;
    let word = if clockwise { &words.cw } else { &words.ccw };
    format!("{word} S{}", fixed(rpm.abs(), 3))
}

/// A program's text up to its first move: `header` as comments, then millimetres, absolute
/// positions and units-per-minute feed. `capacity`: the bytes to reserve.
fn opening(header: &[String], capacity: usize) -> String {
    let mut out = String::with_capacity(capacity);
    for line in header {
        out.push_str(&comment(line));
        out.push('\n');
    }
    out.push_str("G21 G90 G94\n");
    out
}

/// X, Z and B's words for `pose`, with `d` decimals.
fn pose_words(pose: Pose, d: usize) -> String {
    format!(
        "X{} Z{} B{}",
        fixed(pose.x_mm, d),
        fixed(pose.z_mm, d),
        fixed(pose.b_deg, d)
    )
}

/// The program as G-code. `header` lines become comments; `workpiece_rpm` and `tool_rpm` are
/// the signed lab-frame speeds.
pub fn write(
    program: &Program,
    header: &[String],
    workpiece_rpm: f64,
    tool_rpm: f64,
    format: &GcodeFormat,
) -> String {
    let d = format.decimals as usize;
    let mut out = opening(header, 64 * (program.blocks().len() + 16));
    let _ = writeln!(out, "G0 {}", pose_words(program.start(), d));
    let _ = writeln!(
        out,
        "{}",
        spindle_on(&format.workpiece_spindle, workpiece_rpm, true)
    );
    let _ = writeln!(out, "{}", spindle_on(&format.tool_spindle, tool_rpm, false));
    let mut inverse_time = false;
    for (index, block) in program.blocks().iter().enumerate() {
        let p = block.end;
        let polishing = matches!(block.kind, BlockKind::Dwell | BlockKind::Move);
        let want_inverse = polishing && format.feed_mode == FeedMode::InverseTime;
        if want_inverse != inverse_time {
            out.push_str(if want_inverse { "G93\n" } else { "G94\n" });
            inverse_time = want_inverse;
        }
        match program.path_feed_per_min(index) {
            None => {
                let _ = writeln!(out, "G4 P{}", fixed(block.duration_s, TIME_DECIMALS));
            }
            Some(path_feed) => {
                let feed = if inverse_time {
                    60.0 / block.duration_s
                } else {
                    path_feed
                };
                let _ = writeln!(out, "G1 {} F{}", pose_words(p, d), significant(feed));
            }
        }
    }
    if inverse_time {
        out.push_str("G94\n");
    }
    let _ = writeln!(out, "{}", format.tool_spindle.stop);
    let _ = writeln!(out, "{}", format.workpiece_spindle.stop);
    out.push_str("M2\n");
    out
}

/// How a polar program writes C.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CWords {
    /// In [0°, 360°): every block turns C by at most a quarter turn, so a controller that
    /// wraps C and takes the shorter way round takes the plan's way.
    #[default]
    Wrapped,
    /// Cumulative from the start (a C axis without roll-over; the words grow by 360 a turn).
    Unwound,
}

/// A polar program as G-code: C under position control beside X, Z and B, every block a G1 in
/// inverse time (G93, F = 1/duration) — the only feed that states a move of C and X together
/// exactly. The workpiece spindle is C, so it gets no spindle word; the tool's turns at
/// `tool_rpm`.
pub fn write_polar(
    program: &PolarProgram,
    header: &[String],
    tool_rpm: f64,
    format: &GcodeFormat,
    c_words: CWords,
) -> String {
    let d = format.decimals as usize;
    let c_word = |c: f64| match c_words {
        CWords::Unwound => fixed(c, d),
        CWords::Wrapped => {
            // Rounded first, so a C just short of a whole turn is written 0, not 360.
            let scale = 10f64.powi(d as i32);
            fixed(((c * scale).round() / scale).rem_euclid(360.0), d)
        }
    };
    let axes = |p: Pose, c: f64| format!("{} C{}", pose_words(p, d), c_word(c));
    let mut out = opening(header, 72 * (program.blocks().len() + 16));
    let (start, start_c) = program.start();
    let _ = writeln!(out, "G0 {}", axes(start, start_c));
    let _ = writeln!(out, "{}", spindle_on(&format.tool_spindle, tool_rpm, false));
    out.push_str("G93\n");
    for block in program.blocks() {
        let _ = writeln!(
            out,
            "G1 {} F{}",
            axes(block.end, block.c_deg),
            significant(60.0 / block.duration_s)
        );
    }
    out.push_str("G94\n");
    let _ = writeln!(out, "{}", format.tool_spindle.stop);
    out.push_str("M2\n");
    out
}

/// An X-Y program as G-code ([`super::xy_program`]): G0 above the first point, the approach
/// down Z and the retract up in G94 at their feed, the stops as G4, every move of X and Y a G1
/// in inverse time (G93, F = 1/duration), so each block takes exactly its time. With
/// `tool_rpm`, the tool spindle turns at it from before the approach to after the retract.
pub fn write_xy(
    program: &XyProgram,
    header: &[String],
    tool_rpm: Option<f64>,
    format: &GcodeFormat,
) -> String {
    let d = format.decimals as usize;
    let xy = |p: [f64; 3]| format!("X{} Y{}", fixed(p[0], d), fixed(p[1], d));
    let mut out = opening(header, 40 * (program.blocks().len() + 16));
    let start = program.start_mm();
    let _ = writeln!(out, "G0 {} Z{}", xy(start), fixed(start[2], d));
    if let Some(rpm) = tool_rpm {
        let _ = writeln!(out, "{}", spindle_on(&format.tool_spindle, rpm, false));
    }
    let mut inverse_time = false;
    let follows = program.follows_surface();
    for block in program.blocks() {
        let want_inverse = block.kind == BlockKind::Move;
        if want_inverse && !inverse_time {
            out.push_str("G93\n");
            inverse_time = true;
        }
        match block.kind {
            BlockKind::Dwell => {
                let _ = writeln!(out, "G4 P{}", fixed(block.duration_s, TIME_DECIMALS));
            }
            BlockKind::Move => {
                let feed = significant(60.0 / block.duration_s);
                if follows {
                    let z = fixed(block.end_mm[2], d);
                    let _ = writeln!(out, "G1 {} Z{z} F{feed}", xy(block.end_mm));
                } else {
                    let _ = writeln!(out, "G1 {} F{feed}", xy(block.end_mm));
                }
            }
            BlockKind::Approach | BlockKind::Retract => {
                if inverse_time {
                    out.push_str("G94\n");
                    inverse_time = false;
                }
                let feed = significant(program.approach.feed_mm_per_min);
                let _ = writeln!(out, "G1 Z{} F{feed}", fixed(block.end_mm[2], d));
            }
        }
    }
    if inverse_time {
        out.push_str("G94\n");
    }
    if tool_rpm.is_some() {
        let _ = writeln!(out, "{}", format.tool_spindle.stop);
    }
    out.push_str("M2\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_written_plainly() {
        assert_eq!(fixed(-0.00001, 4), "0.0000");
        assert_eq!(fixed(-1.23456, 4), "-1.2346");
        assert_eq!(significant(60.0 / 7.0), "8.571428571");
        assert_eq!(significant(0.06), "0.06000000000");
        assert_eq!(significant(12000.0), "12000.00000");
    }

    #[test]
    fn spindle_directions_follow_the_lab_convention() {
        let (w, t) = (
            SpindleWords::workpiece_default(),
            SpindleWords::tool_default(),
        );
        // Paper experiment 1: workpiece −10 (clockwise from the tool side), tool +200.
        assert_eq!(spindle_on(&w, -10.0, true), "M4 S10.000");
        assert_eq!(spindle_on(&t, 200.0, false), "M4 $1 S200.000");
        assert_eq!(spindle_on(&w, 10.0, true), "M3 S10.000");
        assert_eq!(spindle_on(&t, 0.0, false), "M5 $1");
    }

    #[test]
    fn words_that_would_open_a_comment_are_refused() {
        for word in ["M3 (x", "M3\nG0", "M3;", ""] {
            let spec = GcodeFormatSpec {
                tool_spindle: SpindleWordsSpec {
                    cw: Some(word.into()),
                    ..SpindleWordsSpec::default()
                },
                ..GcodeFormatSpec::default()
            };
            assert!(GcodeFormat::new(spec).is_err(), "{word:?}");
        }
        assert!(GcodeFormat::new(GcodeFormatSpec::default()).is_ok());
    }
}
