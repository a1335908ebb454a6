//! Where the part sits on a map, how the map turns into the machine's frame, and the clear
//! aperture a figure is taken over.
//!
//! **Frames.** A pixel is addressed by its column c (rightwards) and row r (downwards, the top
//! row 0), its centre at (c, r). The part's frame has its origin at the part's centre
//! (c₀, r₀), x to the right and y up, in mm: (x′, y′) = ((c − c₀)·p, (r₀ − r)·p), p the pixel
//! pitch. `mirror` flips x′ (an interferometer that views the part through a fold, or from
//! behind), then `rotation` turns the result counter-clockwise into the machine's C frame:
//! (x, y) = R(φ)·(±x′, y′).
//!
//! **The part's centre and radius**, unless given, come from the valid pixels' outer boundary:
//! the first and last valid pixel of each row and of each column (interior dropouts do not
//! count), fitted with a circle by algebraic least squares (Kåsa: x² + y² + Dx + Ey + F = 0,
//! linear in D, E, F), refitted once without the points more than 3 pixels off it (a notch, a
//! fiducial). The boundary pixels' centres lie inside the part's edge by about half a pixel,
//! which the radius adds back.
//!
//! **Apertures** (all in the part's frame, mm): a circle about the centre, an annulus about it,
//! a rectangle and a circle anywhere. Each has a centre and a radius that normalise the
//! Zernike terms: the circle's own; the rectangle's half-diagonal (its circumscribed circle).

use super::HeightMap;

/// A clear aperture in the part's frame, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Aperture {
    /// A circle about the part's centre.
    Circle { radius_mm: f64 },
    /// The ring inner < ρ ≤ outer about the part's centre.
    Annulus {
        inner_radius_mm: f64,
        outer_radius_mm: f64,
    },
    /// An axis-aligned rectangle (in the C frame) centred at (x, y).
    Rectangle {
        centre_x_mm: f64,
        centre_y_mm: f64,
        width_mm: f64,
        height_mm: f64,
    },
    /// A circle centred at (x, y): an off-axis segment's clear aperture.
    OffCentreCircle {
        centre_x_mm: f64,
        centre_y_mm: f64,
        radius_mm: f64,
    },
}

impl Aperture {
    /// Whether (x, y) (part frame, mm) is inside.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (cx, cy) = self.centre_mm();
        let (dx, dy) = (x - cx, y - cy);
        let rho2 = dx * dx + dy * dy;
        match *self {
            Aperture::Circle { radius_mm } | Aperture::OffCentreCircle { radius_mm, .. } => {
                rho2 <= radius_mm * radius_mm
            }
            Aperture::Annulus {
                inner_radius_mm,
                outer_radius_mm,
            } => {
                rho2 > inner_radius_mm * inner_radius_mm
                    && rho2 <= outer_radius_mm * outer_radius_mm
            }
            Aperture::Rectangle {
                width_mm,
                height_mm,
                ..
            } => dx.abs() <= width_mm / 2.0 && dy.abs() <= height_mm / 2.0,
        }
    }

    /// The centre the Zernike terms are taken about, mm.
    pub fn centre_mm(&self) -> (f64, f64) {
        match *self {
            Aperture::Circle { .. } | Aperture::Annulus { .. } => (0.0, 0.0),
            Aperture::Rectangle {
                centre_x_mm,
                centre_y_mm,
                ..
            }
            | Aperture::OffCentreCircle {
                centre_x_mm,
                centre_y_mm,
                ..
            } => (centre_x_mm, centre_y_mm),
        }
    }

    /// The radius that normalises the Zernike terms (ρ = 1 on it), mm.
    pub fn normalization_radius_mm(&self) -> f64 {
        match *self {
            Aperture::Circle { radius_mm } | Aperture::OffCentreCircle { radius_mm, .. } => {
                radius_mm
            }
            Aperture::Annulus {
                outer_radius_mm, ..
            } => outer_radius_mm,
            Aperture::Rectangle {
                width_mm,
                height_mm,
                ..
            } => width_mm.hypot(height_mm) / 2.0,
        }
    }

    /// Points on the aperture's outline (part frame, mm): what must lie on the map.
    pub fn outline_mm(&self) -> Vec<(f64, f64)> {
        let (cx, cy) = self.centre_mm();
        match *self {
            Aperture::Rectangle {
                width_mm,
                height_mm,
                ..
            } => [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)]
                .iter()
                .map(|(sx, sy)| (cx + sx * width_mm / 2.0, cy + sy * height_mm / 2.0))
                .collect(),
            _ => {
                let r = self.normalization_radius_mm();
                (0..360)
                    .map(|k| {
                        let a = (k as f64).to_radians();
                        (cx + r * a.cos(), cy + r * a.sin())
                    })
                    .collect()
            }
        }
    }
}

/// How the map's pixels sit in the part's C frame (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// The part's centre: column and row (fractional), pixels.
    pub centre_px: (f64, f64),
    /// The part's radius, mm.
    pub part_radius_mm: f64,
    /// Counter-clockwise, degrees.
    pub rotation_deg: f64,
    /// x′ flipped before the rotation.
    pub mirror: bool,
    /// Pixel pitch, mm.
    pub pixel_mm: f64,
}

impl Alignment {
    /// The centre of pixel (column, row) in the part's C frame, mm.
    pub fn to_part(&self, column: f64, row: f64) -> (f64, f64) {
        self.frame().to_part(column, row)
    }

    /// [`Self::to_part`] for many pixels: the rotation's sine and cosine found once.
    pub fn frame(&self) -> Frame {
        let (sin, cos) = self.rotation_deg.to_radians().sin_cos();
        Frame {
            alignment: *self,
            sin,
            cos,
        }
    }

    /// The (column, row) of a point of the part's frame (the inverse of [`Self::to_part`]).
    pub fn to_pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        let (mut u, v) = (c * x + s * y, -s * x + c * y);
        if self.mirror {
            u = -u;
        }
        (
            self.centre_px.0 + u / self.pixel_mm,
            self.centre_px.1 - v / self.pixel_mm,
        )
    }
}

/// An [`Alignment`] with its rotation's sine and cosine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    alignment: Alignment,
    sin: f64,
    cos: f64,
}

impl Frame {
    /// As [`Alignment::to_part`].
    pub fn to_part(&self, column: f64, row: f64) -> (f64, f64) {
        let a = &self.alignment;
        let mut x = (column - a.centre_px.0) * a.pixel_mm;
        let y = (a.centre_px.1 - row) * a.pixel_mm;
        if a.mirror {
            x = -x;
        }
        (self.cos * x - self.sin * y, self.sin * x + self.cos * y)
    }
}

/// The circle through the valid pixels' outer boundary (module docs): centre (column, row)
/// and radius, pixels. `None` when fewer than three boundary pixels or no circle fits.
pub fn boundary_circle(map: &HeightMap) -> Option<((f64, f64), f64)> {
    let w = map.width();
    // One pass in storage order: each row's first and last valid pixel, and each column's
    // first and last valid row so far.
    let mut points = Vec::new();
    let mut columns: Vec<Option<(usize, usize)>> = vec![None; w];
    for (row, heights) in map.heights_nm().chunks(w).enumerate() {
        let mut ends: Option<(usize, usize)> = None;
        for (column, h) in heights.iter().enumerate() {
            if h.is_none() {
                continue;
            }
            ends = Some(ends.map_or((column, column), |(first, _)| (first, column)));
            let span = &mut columns[column];
            *span = Some(span.map_or((row, row), |(first, _)| (first, row)));
        }
        if let Some((first, last)) = ends {
            points.push((first as f64, row as f64));
            if last != first {
                points.push((last as f64, row as f64));
            }
        }
    }
    for (column, span) in columns.iter().enumerate() {
        if let Some((first, last)) = *span {
            points.push((column as f64, first as f64));
            if last != first {
                points.push((column as f64, last as f64));
            }
        }
    }
    let (centre, radius) = kasa(&points)?;
    let kept: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| ((x - centre.0).hypot(y - centre.1) - radius).abs() <= 3.0)
        .collect();
    let (centre, radius) = kasa(&kept)?;
    Some((centre, radius + 0.5))
}

/// The algebraic circle fit x² + y² + Dx + Ey + F = 0, centred on the points' mean for
/// conditioning: centre and radius.
fn kasa(points: &[(f64, f64)]) -> Option<((f64, f64), f64)> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    // Normal equations of [u v 1]·[D E F]ᵀ = −(u² + v²), u = x − mx, v = y − my.
    let mut g = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for (x, y) in points {
        let row = [x - mx, y - my, 1.0];
        let rhs = -(row[0] * row[0] + row[1] * row[1]);
        for i in 0..3 {
            for j in 0..3 {
                g[i][j] += row[i] * row[j];
            }
            b[i] += row[i] * rhs;
        }
    }
    let [d, e, f] = solve3(g, b)?;
    let (cu, cv) = (-d / 2.0, -e / 2.0);
    let r2 = cu * cu + cv * cv - f;
    (r2 > 0.0 && r2.is_finite()).then(|| ((cu + mx, cv + my), r2.sqrt()))
}

/// Solves a 3 × 3 system by Cramer's rule; `None` when singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let scale = a.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    if d.abs() <= 1e-12 * scale.powi(3) || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frames_invert() {
        let a = Alignment {
            centre_px: (200.3, 180.7),
            part_radius_mm: 25.0,
            rotation_deg: 33.0,
            mirror: true,
            pixel_mm: 0.12,
        };
        let (x, y) = a.to_part(17.0, 301.0);
        let (c, r) = a.to_pixel(x, y);
        assert!((c - 17.0).abs() < 1e-12 && (r - 301.0).abs() < 1e-12);
        // Unrotated, unmirrored: right is +x, up is +y.
        let plain = Alignment {
            rotation_deg: 0.0,
            mirror: false,
            ..a
        };
        let (x, y) = plain.to_part(201.3, 179.7);
        assert!((x - 0.12).abs() < 1e-12 && (y - 0.12).abs() < 1e-12);
    }
}
