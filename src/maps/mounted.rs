//! The mounted set's map in C's frame, from each segment's own map (`crate::segments`).
//!
//! Segment i's map is in its own frame as it sat on the parent: its centre pixel (the middle
//! of its rows and columns) at the segment's centre, x (columns, left to right) along e_i,
//! away from C and from the parent's vertex, y (rows, top first) along e_i⊥, counter-clockwise.
//! A pixel p of C's frame on segment i has, with d = p − c_i,
//!
//! ```text
//! u = d·e_i,   v = d·e_i⊥,   column = (w − 1)/2 + u/s_i,   row = (h − 1)/2 − v/s_i
//! ```
//!
//! (s_i segment i's pixel), and takes the bilinear interpolation of the four pixels about
//! (column, row), none of them missing: the height of the plane through them, exact for a
//! tilt and within s²·|∇²z|/8 of a smooth map. The mounted map has the finest of the
//! segments' pixels, C at its middle pixel, and reaches l + a either side; off the segments it
//! has no data.

use super::{HeightMap, MapError};
use crate::segments::SegmentLayout;

/// Why the segments' maps cannot be mounted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MountedError {
    #[error("{count} segments need {count} maps, one each in the layout's order, not {got}")]
    Count { count: usize, got: usize },
    #[error("segment {segment}'s map has no pixel_mm: each segment's map needs its pixel")]
    Pixel { segment: usize },
    #[error("the mounted map: {0}")]
    Map(MapError),
}

/// The mounted set's map (module docs) from `maps`, one per segment of `layout`, at most
/// `max_pixels` pixels.
pub fn mounted(
    layout: &SegmentLayout,
    maps: &[HeightMap],
    max_pixels: usize,
) -> Result<HeightMap, MountedError> {
    let spec = layout.spec();
    if maps.len() != spec.count {
        return Err(MountedError::Count {
            count: spec.count,
            got: maps.len(),
        });
    }
    let mut pixel = f64::INFINITY;
    for (segment, map) in maps.iter().enumerate() {
        pixel = pixel.min(map.pixel_mm().ok_or(MountedError::Pixel { segment })?);
    }
    let reach = spec.mount_radius_mm + spec.aperture_radius_mm;
    let half = (reach / pixel).ceil();
    let n = 2.0 * half + 1.0;
    if n * n > max_pixels as f64 {
        return Err(MountedError::Map(MapError::TooLarge {
            pixels: (n * n) as usize,
            max: max_pixels,
        }));
    }
    let (half, n) = (half as usize, n as usize);
    let rows = (0..n)
        .map(|row| {
            let y = (half as f64 - row as f64) * pixel;
            (0..n)
                .map(|column| {
                    let x = (column as f64 - half as f64) * pixel;
                    let segment = layout.segment_at([x, y])?;
                    let (s, c) = layout.centre_angle(segment).sin_cos();
                    let l = spec.mount_radius_mm;
                    let (dx, dy) = (x - l * c, y - l * s);
                    let (u, v) = (dx * c + dy * s, -dx * s + dy * c);
                    bilinear(&maps[segment], u, v)
                })
                .collect()
        })
        .collect();
    HeightMap::from_rows(rows, Some(pixel), None, max_pixels).map_err(MountedError::Map)
}

/// The map's height at (u, v) mm from its centre pixel (x right, y up), or `None` where any
/// of the four pixels about it has no data or it is off the map.
fn bilinear(map: &HeightMap, u: f64, v: f64) -> Option<f64> {
    let s = map.pixel_mm()?;
    let column = 0.5 * (map.width() as f64 - 1.0) + u / s;
    let row = 0.5 * (map.height() as f64 - 1.0) - v / s;
    if column < 0.0 || row < 0.0 {
        return None;
    }
    let (c0, r0) = (column.floor() as usize, row.floor() as usize);
    let (fc, fr) = (column - c0 as f64, row - r0 as f64);
    // On the last column or row the pixel itself (its neighbour's weight is 0).
    let c1 = if fc > 0.0 { c0 + 1 } else { c0 };
    let r1 = if fr > 0.0 { r0 + 1 } else { r0 };
    let h = |c: usize, r: usize| map.at(c, r);
    Some(
        (1.0 - fr) * ((1.0 - fc) * h(c0, r0)? + fc * h(c1, r0)?)
            + fr * ((1.0 - fc) * h(c0, r1)? + fc * h(c1, r1)?),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segments::four_paraboloid_segments;

    /// A plane in each segment's own frame (a different one each) comes back exactly at every
    /// mounted pixel on the segments (bilinear interpolation is exact for a plane), each
    /// segment's in its own place; off the segments there is no data; a wrong count or a map
    /// without its pixel is refused.
    #[test]
    fn each_segment_s_map_lands_on_its_segment_in_c_s_frame() {
        let layout = four_paraboloid_segments();
        let plane =
            |i: usize, u: f64, v: f64| 3.0 * i as f64 + 0.7 * u - 0.2 * (i as f64 + 1.0) * v;
        let maps: Vec<HeightMap> = (0..4)
            .map(|i| {
                // 61 × 61 pixels of 1 mm: the segment's disc and a little more.
                let rows = (0..61)
                    .map(|r| {
                        (0..61)
                            .map(|c| Some(plane(i, c as f64 - 30.0, 30.0 - r as f64)))
                            .collect()
                    })
                    .collect();
                HeightMap::from_rows(rows, Some(1.0), None, 1 << 20).unwrap()
            })
            .collect();
        let set = mounted(&layout, &maps, 1 << 20).unwrap();
        assert_eq!((set.width(), set.pixel_mm()), (201, Some(1.0)));
        let mut on = [0; 4];
        for row in 0..201 {
            for column in 0..201 {
                let (x, y) = (column as f64 - 100.0, 100.0 - row as f64);
                let got = set.at(column, row);
                match layout.segment_at([x, y]) {
                    None => assert_eq!(got, None),
                    Some(i) => {
                        let phi = layout.centre_angle(i);
                        let (dx, dy) = (x - 70.0 * phi.cos(), y - 70.0 * phi.sin());
                        let (u, v) = (
                            dx * phi.cos() + dy * phi.sin(),
                            -dx * phi.sin() + dy * phi.cos(),
                        );
                        let want = plane(i, u, v);
                        assert!((got.unwrap() - want).abs() < 1e-9, "({x}, {y}) on {i}");
                        on[i] += 1;
                    }
                }
            }
        }
        assert!(on.iter().all(|&k| k > 2700), "{on:?}");
        assert_eq!(
            mounted(&layout, &maps[..3], 1 << 20).unwrap_err(),
            MountedError::Count { count: 4, got: 3 }
        );
        let mut without = maps.clone();
        without[2] = HeightMap::from_rows(vec![vec![Some(1.0)]], None, None, 10).unwrap();
        assert_eq!(
            mounted(&layout, &without, 1 << 20).unwrap_err(),
            MountedError::Pixel { segment: 2 }
        );
    }
}
