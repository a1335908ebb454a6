//! `POST /v1/maps/analysis` against references written here: Zernike polynomials from their
//! explicit factorial sums, least squares by twice-orthogonalised Gram–Schmidt, maps written
//! by an independent generator in every format, and figures whose value follows from the
//! map's symmetry.

use serde_json::{json, Value};

use super::common::http::{app, post_json, post_with};
use super::maps::{reference, sample, synthetic};

const PATH: &str = "/v1/maps/analysis";

/// R_n^m(ρ) by its explicit sum Σ_s (−1)^s (n − s)! / (s! ((n + m)/2 − s)! ((n − m)/2 − s)!)
/// ρ^(n − 2s) (exact enough for n ≤ 12: the terms stay below 10⁴).
fn radial(n: u32, m: u32, rho: f64) -> f64 {
    let f = |k: u32| (1..=k).map(f64::from).product::<f64>();
    (0..=(n - m) / 2)
        .map(|s| {
            let sign = if s % 2 == 0 { 1.0 } else { -1.0 };
            sign * f(n - s) / (f(s) * f((n + m) / 2 - s) * f((n - m) / 2 - s))
                * rho.powi((n - 2 * s) as i32)
        })
        .sum()
}

/// The unit-RMS Zernike term (n, m) at (x, y) of the unit disc: m > 0 cos, m < 0 sin.
fn zernike(n: u32, m: i32, x: f64, y: f64) -> f64 {
    let (rho, theta) = (x.hypot(y), y.atan2(x));
    let k = m.unsigned_abs();
    let norm = if m == 0 {
        f64::from(n + 1).sqrt()
    } else {
        (2.0 * f64::from(n + 1)).sqrt()
    };
    let angular = match m.signum() {
        1 => (f64::from(k) * theta).cos(),
        -1 => (f64::from(k) * theta).sin(),
        _ => 1.0,
    };
    norm * radial(n, k, rho) * angular
}

/// The Fringe set as Zygo and Code V publish it (index 1 … 37).
const FRINGE: [(u32, i32); 37] = [
    (0, 0),
    (1, 1),
    (1, -1),
    (2, 0),
    (2, 2),
    (2, -2),
    (3, 1),
    (3, -1),
    (4, 0),
    (3, 3),
    (3, -3),
    (4, 2),
    (4, -2),
    (5, 1),
    (5, -1),
    (6, 0),
    (4, 4),
    (4, -4),
    (5, 3),
    (5, -3),
    (6, 2),
    (6, -2),
    (7, 1),
    (7, -1),
    (8, 0),
    (5, 5),
    (5, -5),
    (6, 4),
    (6, -4),
    (7, 3),
    (7, -3),
    (8, 2),
    (8, -2),
    (9, 1),
    (9, -1),
    (10, 0),
    (12, 0),
];

/// Least squares by Gram–Schmidt orthogonalised twice (as accurate as Householder QR): the
/// coefficients of `columns` that fit `data`.
fn least_squares(columns: &[Vec<f64>], data: &[f64]) -> Vec<f64> {
    let j = columns.len();
    let mut q: Vec<Vec<f64>> = Vec::with_capacity(j);
    let mut r = vec![vec![0.0; j]; j];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    for (k, column) in columns.iter().enumerate() {
        let mut v = column.clone();
        for _ in 0..2 {
            for (i, qi) in q.iter().enumerate() {
                let c = dot(qi, &v);
                r[i][k] += c;
                v.iter_mut().zip(qi).for_each(|(a, b)| *a -= c * b);
            }
        }
        let norm = dot(&v, &v).sqrt();
        r[k][k] = norm;
        q.push(v.iter().map(|a| a / norm).collect());
    }
    let qtb: Vec<f64> = q.iter().map(|qi| dot(qi, data)).collect();
    let mut c = vec![0.0; j];
    for k in (0..j).rev() {
        c[k] = (qtb[k] - (k + 1..j).map(|i| r[k][i] * c[i]).sum::<f64>()) / r[k][k];
    }
    c
}

fn number(v: &Value, path: &str) -> f64 {
    path.split('.')
        .fold(v, |v, key| &v[key])
        .as_f64()
        .unwrap_or_else(|| panic!("{path} is not a number in {v}"))
}

/// The real Fizeau map, sent as the file: its 37 Fringe coefficients (unit RMS) agree with an
/// independent least-squares fit of the independent reader's pixels, within 1e-9 of the
/// map's RMS, on the alignment the service reports (the fitted centre and radius are inputs
/// of the fit, not what is checked here).
#[tokio::test]
async fn the_fizeau_sample_fits_as_an_independent_least_squares_does() {
    let bytes = sample();
    let reply = post_with(
        &app(),
        PATH,
        bytes.clone(),
        &[("content-type", "application/octet-stream")],
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let a = reply.json();
    assert_eq!(a["map"]["format"], "metropro_dat");
    assert_eq!(a["zernike"]["ordering"], "fringe");
    let (cx, cy) = (
        number(&a, "alignment.centre_x_px"),
        number(&a, "alignment.centre_y_px"),
    );
    let radius = number(&a, "clear_aperture.aperture.radius_mm");
    let pixel = number(&a, "map.pixel_mm");
    let (w, _, heights) = reference(&bytes);
    let mut points = Vec::new();
    for (k, h) in heights.iter().enumerate() {
        let (c, r) = ((k % w) as f64, (k / w) as f64);
        let (x, y) = ((c - cx) * pixel, (cy - r) * pixel);
        if h.is_finite() && x * x + y * y <= radius * radius {
            points.push((x / radius, y / radius, *h));
        }
    }
    assert_eq!(points.len() as f64, number(&a, "clear_aperture.pixels"));
    let data: Vec<f64> = points.iter().map(|p| p.2).collect();
    // Less the least-squares plane.
    let plane = [
        points.iter().map(|_| 1.0).collect::<Vec<_>>(),
        points.iter().map(|p| p.0).collect(),
        points.iter().map(|p| p.1).collect(),
    ];
    let c = least_squares(&plane, &data);
    let residual: Vec<f64> = points
        .iter()
        .map(|&(x, y, h)| h - c[0] - c[1] * x - c[2] * y)
        .collect();
    let columns: Vec<Vec<f64>> = FRINGE
        .iter()
        .map(|&(n, m)| {
            points
                .iter()
                .map(|&(x, y, _)| zernike(n, m, x, y))
                .collect()
        })
        .collect();
    let expected = least_squares(&columns, &residual);
    let rms = number(&a, "metrics.rms_nm");
    let terms = a["zernike"]["terms"].as_array().unwrap();
    assert_eq!(terms.len(), 37);
    let mut worst: f64 = 0.0;
    for (k, (t, e)) in terms.iter().zip(&expected).enumerate() {
        assert_eq!(
            (
                t["n"].as_u64().unwrap() as u32,
                t["m"].as_i64().unwrap() as i32
            ),
            FRINGE[k]
        );
        assert_eq!(t["index"], k + 1);
        worst = worst.max((number(t, "coefficient_nm") - e).abs());
    }
    assert!(
        worst <= 1e-9 * rms,
        "worst {worst:e} nm against RMS {rms} nm"
    );
    println!(
        "sample: {} pixels in the aperture, RMS {rms:.6} nm, worst coefficient difference {worst:.2e} nm; \
         defocus {:.4} nm, spherical {:.4} nm",
        points.len(),
        number(&terms[3], "coefficient_nm"),
        number(&terms[8], "coefficient_nm")
    );
}

/// The orderings convert into one another: every term of each ordering maps to (n, m) and
/// back to its own index, and the Fringe set's terms carry their Noll and ANSI indices
/// round trip (Fringe → Noll → ANSI → Fringe), fits in each ordering giving each term the
/// same coefficient.
#[tokio::test]
async fn fringe_noll_and_ansi_convert_round_trip() {
    use preston::maps::zernike::Ordering;
    for ordering in [Ordering::Fringe, Ordering::Noll, Ordering::Ansi] {
        let first = ordering.first_index();
        for j in first..first + ordering.max_terms() {
            let term = ordering.term(j).unwrap();
            assert_eq!(ordering.index(term), Some(j), "{ordering:?} {j}");
        }
    }
    for (k, &(n, m)) in FRINGE.iter().enumerate() {
        let term = Ordering::Fringe.term(k + 1).unwrap();
        assert_eq!((term.n, term.m), (n, m));
        let noll = Ordering::Noll.index(term).unwrap();
        let ansi = Ordering::Ansi
            .index(Ordering::Noll.term(noll).unwrap())
            .unwrap();
        let back = Ordering::Fringe
            .index(Ordering::Ansi.term(ansi).unwrap())
            .unwrap();
        assert_eq!(back, k + 1);
        assert_eq!(
            ansi as i64,
            (i64::from(n) * (i64::from(n) + 2) + i64::from(m)) / 2
        );
    }
    // The same map in Noll (the 45 terms through n = 8, which hold the Fringe terms to n = 8)
    // and in Fringe: each shared term's coefficient is the same where the two sets fit the
    // same terms. Through n = 8 Noll holds all 45; Fringe's first 25 are all within n ≤ 8.
    let body = |ordering: &str, terms: usize| {
        let mut b: Value =
            serde_json::from_str(include_str!("../../fixtures/maps_analysis.json")).unwrap();
        b["zernike"] = json!({"ordering": ordering, "terms": terms});
        b.to_string()
    };
    let app = app();
    let noll = post_json(&app, PATH, body("noll", 45)).await.json();
    let ansi = post_json(&app, PATH, body("ansi", 45)).await.json();
    let by_nm = |a: &Value| -> std::collections::HashMap<(i64, i64), f64> {
        a["zernike"]["terms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                (
                    (t["n"].as_i64().unwrap(), t["m"].as_i64().unwrap()),
                    number(t, "coefficient_nm"),
                )
            })
            .collect()
    };
    let (noll, ansi) = (by_nm(&noll), by_nm(&ansi));
    assert_eq!(noll.len(), 45);
    for (key, value) in &noll {
        assert!(
            (value - ansi[key]).abs() <= 1e-11 * value.abs().max(1.0),
            "{key:?}"
        );
    }
}

/// A square grid of pixels centred on the part: the generator's pixel pitch and radius.
struct Grid {
    size: usize,
    pixel_mm: f64,
    radius_mm: f64,
}

impl Grid {
    fn centre(&self) -> f64 {
        (self.size - 1) as f64 / 2.0
    }

    /// (x, y) in mm, y up, of pixel (column, row).
    fn position(&self, column: usize, row: usize) -> (f64, f64) {
        let c = self.centre();
        (
            (column as f64 - c) * self.pixel_mm,
            (c - row as f64) * self.pixel_mm,
        )
    }

    /// Rows of heights, `f` of (x/R, y/R) within 1.02 R (a margin beyond the aperture), else
    /// missing.
    fn rows(&self, f: &dyn Fn(f64, f64) -> f64) -> Vec<Vec<Option<f64>>> {
        (0..self.size)
            .map(|row| {
                (0..self.size)
                    .map(|column| {
                        let (x, y) = self.position(column, row);
                        let (u, v) = (x / self.radius_mm, y / self.radius_mm);
                        (u.hypot(v) <= 1.02).then(|| f(u, v))
                    })
                    .collect()
            })
            .collect()
    }

    fn request(&self, rows: Vec<Vec<Option<f64>>>, extra: Value) -> String {
        let mut body = json!({
            "map": {"heights_nm": rows, "pixel_mm": self.pixel_mm},
            "alignment": {
                "centre_x_px": self.centre(),
                "centre_y_px": self.centre(),
                "part_radius_mm": self.radius_mm,
            },
        });
        for (k, v) in extra.as_object().unwrap() {
            body[k] = v.clone();
        }
        body.to_string()
    }
}

/// Planted Zernike terms (unit RMS, Noll 4 … 28 with random coefficients, and a few of
/// higher order) come back to 1e-10 nm from a fit of 231 Noll terms (every term through
/// n = 20, the others 0 to the same bound): the map less piston and tilt is in the span of
/// the terms fitted.
#[tokio::test]
async fn planted_zernike_terms_are_recovered() {
    use preston::maps::zernike::Ordering;
    let grid = Grid {
        size: 241,
        pixel_mm: 0.1,
        radius_mm: 11.5,
    };
    let mut rng = fastrand::Rng::with_seed(49);
    let mut planted: Vec<((u32, i32), f64)> = (4..=28)
        .map(|j| {
            let t = Ordering::Noll.term(j).unwrap();
            ((t.n, t.m), rng.f64() * 40.0 - 20.0)
        })
        .collect();
    planted.extend([((10, 4), 3.0), ((11, -7), -2.5), ((12, 0), 1.25)]);
    let f = |u: f64, v: f64| {
        planted
            .iter()
            .map(|&((n, m), c)| c * zernike(n, m, u, v))
            .sum()
    };
    let body = grid.request(
        grid.rows(&f),
        json!({"zernike": {"ordering": "noll", "terms": 231}}),
    );
    let reply = post_json(&app(), PATH, body).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let a = reply.json();
    let mut worst: f64 = 0.0;
    for t in a["zernike"]["terms"].as_array().unwrap() {
        let key = (
            t["n"].as_u64().unwrap() as u32,
            t["m"].as_i64().unwrap() as i32,
        );
        if key.0 <= 1 {
            continue; // piston and tilt were removed first
        }
        let want = planted.iter().find(|p| p.0 == key).map_or(0.0, |p| p.1);
        worst = worst.max((number(t, "coefficient_nm") - want).abs());
    }
    assert!(worst <= 1e-10, "worst {worst:e} nm");
    assert!(number(&a, "zernike.residual_rms_nm") <= 1e-10);
    println!("planted terms: worst difference {worst:.2e} nm over 228 terms");
}

/// Defocus and astigmatism on a grid symmetric under a quarter turn: the figures follow by
/// hand. Power is the planted defocus's edge-to-centre height, x² − y² being orthogonal to
/// 1, x, y and ρ² over any such pixel set; the irregularity is the astigmatism alone, its PV
/// and RMS those of b(x² − y²)/R² over the pixels; its rotationally symmetric part vanishes
/// (RSI = RMSs = 0, RMSa = RMSi) since each ring's pixels cancel in pairs; in fringes a
/// height over λ/2.
#[tokio::test]
async fn iso_figures_match_a_hand_computation() {
    let grid = Grid {
        size: 201,
        pixel_mm: 0.2,
        radius_mm: 19.0,
    };
    let (a, b) = (30.0, 12.0);
    let f = |u: f64, v: f64| a * (2.0 * (u * u + v * v) - 1.0) + b * (u * u - v * v);
    let body = grid.request(grid.rows(&f), json!({"fringe_wavelength_nm": 632.8}));
    let reply = post_json(&app(), PATH, body).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let r = reply.json();
    let astig: Vec<f64> = (0..grid.size * grid.size)
        .filter_map(|k| {
            let (x, y) = grid.position(k % grid.size, k / grid.size);
            (x * x + y * y <= grid.radius_mm.powi(2))
                .then(|| b * (x * x - y * y) / grid.radius_mm.powi(2))
        })
        .collect();
    let n = astig.len() as f64;
    let pv = astig.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - astig.iter().cloned().fold(f64::INFINITY, f64::min);
    let mean = astig.iter().sum::<f64>() / n;
    let rms = (astig.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let iso = &r["iso_10110"];
    let close = |got: f64, want: f64, what: &str| {
        assert!(
            (got - want).abs() <= 1e-9 * want.abs().max(1.0),
            "{what}: {got} vs {want}"
        );
    };
    close(number(iso, "power_nm"), 2.0 * a, "power");
    close(number(iso, "irregularity_nm"), pv, "irregularity");
    close(number(iso, "rms_i_nm"), rms, "RMSi");
    close(number(iso, "rms_a_nm"), rms, "RMSa");
    assert!(number(iso, "rotationally_symmetric_irregularity_nm") <= 1e-9);
    assert!(number(iso, "rms_s_nm") <= 1e-9);
    close(
        number(iso, "power_fringes"),
        2.0 * a / (632.8 / 2.0),
        "power in fringes",
    );
    // RMSt: the whole map less its mean (no tilt by symmetry).
    let all: Vec<f64> = (0..grid.size * grid.size)
        .filter_map(|k| {
            let (x, y) = grid.position(k % grid.size, k / grid.size);
            let (u, v) = (x / grid.radius_mm, y / grid.radius_mm);
            (u * u + v * v <= 1.0).then(|| f(u, v))
        })
        .collect();
    let m = all.iter().sum::<f64>() / all.len() as f64;
    let rms_t = (all.iter().map(|v| (v - m).powi(2)).sum::<f64>() / all.len() as f64).sqrt();
    close(number(iso, "rms_t_nm"), rms_t, "RMSt");
    close(number(&r, "metrics.rms_nm"), rms_t, "metrics RMS");
    // What a plan in radius alone leaves is the astigmatism.
    close(
        number(&r, "non_axisymmetric.rms_nm"),
        rms,
        "non-axisymmetric RMS",
    );
}

/// An axisymmetric map (defocus, spherical and secondary spherical: a cubic in r²): its radial
/// profile is the generator's less the removed piston, to 1e-9 of its PV, and the map's RMS
/// is the profile's, area-weighted (2πr dr), to the pixel disc's resolution.
#[tokio::test]
async fn an_axisymmetric_map_has_the_generators_profile() {
    let grid = Grid {
        size: 301,
        pixel_mm: 0.1,
        radius_mm: 14.5,
    };
    let g = |rho: f64| 25.0 * radial(2, 0, rho) - 8.0 * radial(4, 0, rho) + 3.0 * radial(6, 0, rho);
    let body = grid.request(grid.rows(&|u, v| g(u.hypot(v))), json!({}));
    let reply = post_json(&app(), PATH, body).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let a = reply.json();
    let piston = number(&a, "removed.piston_nm");
    let radii: Vec<f64> = serde_json::from_value(a["radial_profile"]["radius_mm"].clone()).unwrap();
    let depth: Vec<f64> = serde_json::from_value(a["radial_profile"]["depth_nm"].clone()).unwrap();
    let pv = number(&a, "metrics.pv_nm");
    let worst = radii
        .iter()
        .zip(&depth)
        .map(|(r, d)| (d + piston - g(r / grid.radius_mm)).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9 * pv, "worst {worst:e} of PV {pv}");
    assert!(number(&a, "non_axisymmetric.rms_nm") <= 1e-9 * pv);
    // The profile's area-weighted RMS over the disc (Simpson on a fine grid of the generator's
    // own profile, which the reported one equals) against the pixels': they differ by the
    // pixel disc's boundary, O(1/R) with R = 145 pixels.
    let k = 20_000;
    let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for i in 0..=k {
        let rho = i as f64 / k as f64;
        let w = if i == 0 || i == k {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let v = g(rho);
        s0 += w * rho;
        s1 += w * rho * v;
        s2 += w * rho * v * v;
    }
    let mean = s1 / s0;
    let profile_rms = (s2 / s0 - mean * mean).sqrt();
    let map_rms = number(&a, "metrics.rms_nm");
    let relative = (map_rms - profile_rms).abs() / profile_rms;
    assert!(relative <= 5e-3, "{map_rms} vs {profile_rms}: {relative:e}");
    println!("axisymmetric: profile within {worst:.2e} nm; RMS {map_rms:.6} (pixels) vs {profile_rms:.6} (profile, area-weighted), {relative:.1e} apart");
}

/// Zygo's XYZ export of integer phase counts: header of the ASCII format, then x y z(µm).
fn as_zygo_xyz(w: usize, h: usize, heights: &[Option<f64>], wavelength_m: f64) -> String {
    let mut text = String::from("Zygo XYZ Data File - Format 1\n");
    text.push_str("0 8 1 0 \"Tue Nov 27 04:00:00 2026\"\n0 0 0 0 0 0\n");
    text.push_str(&format!("0 0 {w} {h}\n\"\"\n\"\"\n\"\"\n"));
    text.push_str(&format!("0 0.5 {wavelength_m:e} 0 1.25 1 2.5e-4 0\n"));
    text.push_str(
        "640 480 0 0 0 0 \"\"\n0 0 0 0 0 0 0 0 0 0\n1 1 20 2 0 0 0 0 0\n0 \"\"\n1 0\n\"\"\n#\n",
    );
    for (k, v) in heights.iter().enumerate() {
        let (x, y) = (k % w, k / w);
        match v {
            Some(nm) => text.push_str(&format!("{x} {y} {}\n", nm / 1e3)),
            None => text.push_str(&format!("{x} {y} No Data\n")),
        }
    }
    text.push_str("#\n");
    text
}

/// Zygo's ASCII export: the same header, an empty intensity block, the counts.
fn as_zygo_ascii(w: usize, h: usize, raw: &[i32], wavelength_m: f64) -> String {
    let xyz = as_zygo_xyz(w, h, &[], wavelength_m);
    let header = xyz
        .split("#\n")
        .next()
        .unwrap()
        .replace("XYZ Data File - Format 1", "ASCII Data File - Format 2");
    let counts: Vec<String> = raw.iter().map(|r| r.to_string()).collect();
    let body: Vec<String> = counts.chunks(10).map(|c| c.join(" ")).collect();
    format!("{header}#\n#\n{}\n#\n", body.join("\n"))
}

/// The same map written as a MetroPro .dat, Zygo XYZ and ASCII exports, a Code V grid, a
/// text grid, a JSON file and a JSON request: every number of the analysis agrees to 1e-12
/// (relative to the larger, or absolute below 1 nm: the formats store the same heights to
/// the last bit or within a few ulps of a decimal conversion).
#[tokio::test]
async fn the_same_map_in_every_format_gives_the_same_analysis() {
    let (w, h) = (96_usize, 90_usize);
    // Phase counts at R = 32768 (code 1): a tilted, astigmatic, zonal part, missing outside
    // a disc of 40 pixels about (47.5, 44.3).
    let raw: Vec<i32> = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f64 - 47.5, (k / w) as f64 - 44.3);
            let r = x.hypot(y) / 40.0;
            if r > 1.0 {
                return 2_147_483_647;
            }
            let t = 900.0 * (2.0 * r * r - 1.0)
                + 300.0 * (x * x - y * y) / 1600.0
                + 12.0 * x
                + 150.0 * (12.0 * r).sin();
            t.round() as i32
        })
        .collect();
    let dat = synthetic(2, 1, w as u16, h as u16, &raw);
    let wavelength_m = f64::from(632.8e-9_f32);
    let nm_per_count = f64::from(0.5_f32) * f64::from(1.25_f32) * wavelength_m / 32768.0 * 1e9;
    let heights: Vec<Option<f64>> = raw
        .iter()
        .map(|&r| (r < 2_147_483_640).then(|| f64::from(r) * nm_per_count))
        .collect();
    let rows: Vec<Vec<Option<f64>>> = heights.chunks(w).map(<[_]>::to_vec).collect();
    let grid_text = {
        let mut t = String::from("# pixel_mm: 0.25\n# unit: nm\n");
        for row in &rows {
            let cells: Vec<String> = row
                .iter()
                .map(|v| v.map_or(String::new(), |v| v.to_string()))
                .collect();
            t.push_str(&cells.join(","));
            t.push('\n');
        }
        t
    };
    let codev = {
        // c counts per SSZ waves of WVL µm: SSZ = R / (S·O) gives the .dat's scale.
        let mut t = format!(
            "! written by the tests\nthe same map\nGRD {w} {h} SUR WVL {} SSZ {} NDA -99999\n",
            wavelength_m * 1e6,
            32768.0 / (0.5 * 1.25)
        );
        let counts: Vec<String> = raw
            .iter()
            .map(|&r| {
                if r < 2_147_483_640 {
                    r.to_string()
                } else {
                    "-99999".into()
                }
            })
            .collect();
        for chunk in counts.chunks(10) {
            t.push_str(&chunk.join(" "));
            t.push('\n');
        }
        t
    };
    let json_file = json!({"heights_nm": rows, "pixel_mm": 0.25}).to_string();
    let query = "?pixel_mm=0.25&fringe_wavelength_nm=632.8&zernike=%7B%22terms%22%3A37%7D";
    let app = app();
    let mut answers = Vec::new();
    for (name, bytes, media) in [
        ("dat", dat, "application/octet-stream"),
        (
            "xyz",
            as_zygo_xyz(w, h, &heights, wavelength_m).into_bytes(),
            "text/plain",
        ),
        (
            "ascii",
            as_zygo_ascii(w, h, &raw, wavelength_m).into_bytes(),
            "text/plain",
        ),
        ("codev", codev.into_bytes(), "text/plain"),
        ("grid", grid_text.into_bytes(), "text/csv"),
        (
            "json file",
            json_file.into_bytes(),
            "application/octet-stream",
        ),
    ] {
        let reply = post_with(
            &app,
            &format!("{PATH}{query}"),
            bytes,
            &[("content-type", media)],
        )
        .await;
        assert_eq!(reply.status, 200, "{name}: {}", reply.text());
        answers.push((name, reply.json()));
    }
    let request = json!({
        "map": {"heights_nm": rows},
        "pixel_mm": 0.25,
        "fringe_wavelength_nm": 632.8,
        "zernike": {"terms": 37},
    });
    let reply = post_json(&app, PATH, request.to_string()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    answers.push(("json request", reply.json()));
    let formats: Vec<&str> = answers
        .iter()
        .map(|(_, a)| a["map"]["format"].as_str().unwrap())
        .collect();
    assert_eq!(
        formats,
        [
            "metropro_dat",
            "zygo_text",
            "zygo_text",
            "codev_int",
            "text_grid",
            "json",
            "json"
        ]
    );
    fn compare(a: &Value, b: &Value, path: &str, worst: &mut f64) {
        match (a, b) {
            (Value::Object(x), Value::Object(y)) => {
                for (k, v) in x {
                    if path.is_empty() && k == "map" {
                        continue;
                    }
                    compare(v, &y[k], &format!("{path}.{k}"), worst);
                }
            }
            (Value::Array(x), Value::Array(y)) => {
                assert_eq!(x.len(), y.len(), "{path}");
                for (i, (u, v)) in x.iter().zip(y).enumerate() {
                    compare(u, v, &format!("{path}[{i}]"), worst);
                }
            }
            (Value::Number(_), Value::Number(_)) => {
                let (u, v) = (a.as_f64().unwrap(), b.as_f64().unwrap());
                let d = (u - v).abs() / u.abs().max(v.abs()).max(1.0);
                assert!(d <= 1e-12, "{path}: {u} vs {v}");
                *worst = worst.max(d);
            }
            _ => assert_eq!(a, b, "{path}"),
        }
    }
    let mut worst: f64 = 0.0;
    for (name, answer) in &answers[1..] {
        let _ = name;
        compare(&answers[0].1, answer, "", &mut worst);
    }
    println!(
        "seven forms of one map: every number within {worst:.1e} (relative, or absolute below 1)"
    );
}

const DIFFERENCE: &str = "/v1/maps/difference";

/// A planted removal: a uniform 50 nm and a 3 nm ring (Gaussian, at 0.6 R, 0.15 R wide) taken
/// off a figure of astigmatism, a zone and a ripple. Every compared pixel's removal is the
/// planted one to 1e-9 nm; the mean and PV are those of the planted removal over the same
/// pixels; the radial removal follows the ring to the spline's resolution; each map's band RMS
/// add up (in quadrature) to its window-weighted RMS, computed here with the documented
/// window (Parseval).
#[tokio::test]
async fn a_planted_removal_is_recovered() {
    let grid = Grid {
        size: 201,
        pixel_mm: 0.2,
        radius_mm: 19.0,
    };
    let figure = |u: f64, v: f64| {
        30.0 * (u * u - v * v) + 5.0 * (8.0 * u.hypot(v)).sin() + 2.0 * (25.0 * u).cos() + 7.0 * v
    };
    let ring = |u: f64, v: f64| 3.0 * (-((u.hypot(v) - 0.6) / 0.15).powi(2)).exp();
    let before = grid.rows(&figure);
    let after = grid.rows(&|u, v| figure(u, v) - 50.0 - ring(u, v));
    let body = json!({
        "before": {"heights_nm": before, "pixel_mm": grid.pixel_mm},
        "after": {"heights_nm": after, "pixel_mm": grid.pixel_mm},
        "alignment": {"centre_x_px": grid.centre(), "centre_y_px": grid.centre(), "part_radius_mm": grid.radius_mm},
    })
    .to_string();
    let app = app();
    let reply = post_json(&app, DIFFERENCE, body.clone()).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let d = reply.json();
    // The planted removal over the aperture's pixels, by hand.
    let mut planted = Vec::new();
    let mut figures = Vec::new();
    for k in 0..grid.size * grid.size {
        let (x, y) = grid.position(k % grid.size, k / grid.size);
        if x * x + y * y <= grid.radius_mm.powi(2) {
            let (u, v) = (x / grid.radius_mm, y / grid.radius_mm);
            planted.push(50.0 + ring(u, v));
            figures.push((u, v, figure(u, v), figure(u, v) - 50.0 - ring(u, v)));
        }
    }
    let n = planted.len() as f64;
    let mean = planted.iter().sum::<f64>() / n;
    let pv = planted.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - planted.iter().cloned().fold(f64::INFINITY, f64::min);
    assert_eq!(d["removal"]["pixels"], planted.len());
    assert!(
        (number(&d, "removal.mean_nm") - mean).abs() <= 1e-9,
        "{}",
        d["removal"]
    );
    assert!((number(&d, "removal.pv_nm") - pv).abs() <= 1e-9);
    // Pixel by pixel, from the CSV.
    let csv = post_with(
        &app,
        DIFFERENCE,
        body,
        &[("content-type", "application/json"), ("accept", "text/csv")],
    )
    .await
    .text();
    let mut worst: f64 = 0.0;
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|c| c.trim().parse().unwrap()).collect();
        let (u, w) = (v[0] / grid.radius_mm, v[1] / grid.radius_mm);
        worst = worst.max((v[2] - 50.0 - ring(u, w)).abs());
    }
    assert!(worst <= 1e-9, "worst pixel {worst:e} nm");
    // The radial removal against the ring.
    let radii: Vec<f64> = serde_json::from_value(d["radial_removal"]["radius_mm"].clone()).unwrap();
    let depth: Vec<f64> = serde_json::from_value(d["radial_removal"]["depth_nm"].clone()).unwrap();
    let radial = radii
        .iter()
        .zip(&depth)
        .map(|(r, e)| (e - 50.0 - ring(r / grid.radius_mm, 0.0)).abs())
        .fold(0.0, f64::max);
    // A cubic spline in r² with knots 2 pixels (0.4 mm) apart follows a ring 2.85 mm wide to
    // ~(h/w)⁴ of its height: 1e-4 nm bounds it with room (measured 9.4e-6).
    assert!(
        radial <= 1e-4,
        "radial removal within {radial} nm of the ring"
    );
    // Parseval on each map: the bands add up to the window-weighted RMS of the map less its
    // least-squares plane (the test's own plane and Sidick window, 1 − ρ⁸).
    for (which, index) in [("before", 2), ("after", 3)] {
        let columns = [
            figures.iter().map(|_| 1.0).collect::<Vec<_>>(),
            figures.iter().map(|f| f.0).collect(),
            figures.iter().map(|f| f.1).collect(),
        ];
        let heights: Vec<f64> = figures
            .iter()
            .map(|f| if index == 2 { f.2 } else { f.3 })
            .collect();
        let c = least_squares(&columns, &heights);
        let (mut num, mut den) = (0.0, 0.0);
        for (f, h) in figures.iter().zip(&heights) {
            let w = 1.0 - f.0.hypot(f.1).powi(8);
            let flat = h - c[0] - c[1] * f.0 - c[2] * f.1;
            num += (flat * w).powi(2);
            den += w * w;
        }
        let weighted = (num / den).sqrt();
        let bands: f64 = d[which]["bands"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b| number(b, "rms_nm").powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            (bands - weighted).abs() <= 1e-9 * weighted,
            "{which}: {bands} vs {weighted}"
        );
    }
    println!(
        "planted removal: pixels within {worst:.1e} nm, mean {mean:.9} nm, radial within {radial:.1e} nm; \
         band RMS before {} after {}",
        d["before"]["bands"], d["after"]["bands"]
    );
}

/// Two MetroPro files as multipart/form-data, the after map shifted by (3, −2) pixels and
/// 40 counts lower everywhere: registered by the given offset, the removal is 40 counts at
/// every compared pixel.
#[tokio::test]
async fn two_dat_files_register_by_an_offset() {
    let (w, h) = (80_usize, 76_usize);
    let (cx, cy) = (39.0, 37.0);
    let raw = |dx: f64, dy: f64, minus: i32| -> Vec<i32> {
        (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f64 - cx - dx, (k / w) as f64 - cy - dy);
                if x.hypot(y) > 34.0 {
                    return 2_147_483_647;
                }
                (800.0 * (x * x - y * y) / 1156.0 + 300.0 * (x / 5.0).sin()).round() as i32 - minus
            })
            .collect()
    };
    let before = synthetic(1, 1, w as u16, h as u16, &raw(0.0, 0.0, 0));
    let after = synthetic(1, 1, w as u16, h as u16, &raw(3.0, -2.0, 40));
    let boundary = "preston-test-boundary";
    let mut body = Vec::new();
    for (name, bytes) in [("before", &before), ("after", &after)] {
        body.extend(
            format!(
                "--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"; filename=\"{name}.dat\"\r\n\
                 Content-Type: application/octet-stream\r\n\r\n"
            )
            .bytes(),
        );
        body.extend(bytes.iter());
        body.extend(b"\r\n");
    }
    body.extend(format!("--{boundary}--\r\n").bytes());
    let query = format!(
        "?pixel_mm=0.25&alignment={}&after_offset_px={}&clear_aperture={}",
        urlencode(
            &json!({"centre_x_px": cx, "centre_y_px": cy, "part_radius_mm": 8.5}).to_string()
        ),
        urlencode(&json!({"x_px": 3, "y_px": -2}).to_string()),
        urlencode(&json!({"shape": "circle", "radius_mm": 7.5}).to_string()),
    );
    let reply = post_with(
        &app(),
        &format!("{DIFFERENCE}{query}"),
        body,
        &[(
            "content-type",
            &format!("multipart/form-data; boundary={boundary}"),
        )],
    )
    .await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let d = reply.json();
    let nm_per_count =
        f64::from(0.5_f32) * f64::from(1.25_f32) * f64::from(632.8e-9_f32) / 32768.0 * 1e9;
    assert_eq!(d["registration"]["before_format"], "metropro_dat");
    assert_eq!(d["registration"]["after_centre_px"], json!([42.0, 35.0]));
    assert!((number(&d, "removal.mean_nm") - 40.0 * nm_per_count).abs() <= 1e-9);
    assert!(number(&d, "removal.pv_nm") <= 1e-9);
    assert_eq!(d["removal"]["uncovered_pixels"], 0);
}

fn urlencode(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// `Accept: image/svg+xml`: one well-formed document, a bar per Zernike term (each bar's
/// height in proportion to its coefficient) above the PSD's curve.
#[tokio::test]
async fn the_analysis_draws_its_zernike_bars_and_psd() {
    let body = include_str!("../../fixtures/maps_analysis.json");
    let app = app();
    let json = post_json(&app, PATH, body).await.json();
    let reply = post_with(
        &app,
        PATH,
        body,
        &[
            ("content-type", "application/json"),
            ("accept", "image/svg+xml"),
        ],
    )
    .await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.content_type, "image/svg+xml");
    let text = reply.text();
    let doc = roxmltree::Document::parse(&text).expect("well-formed SVG");
    let bars: Vec<roxmltree::Node> = doc
        .descendants()
        .filter(|n| {
            n.has_tag_name("rect")
                && n.attribute("fill")
                    .is_some_and(|f| f.eq_ignore_ascii_case("#1F77B4"))
        })
        .collect();
    let terms = json["zernike"]["terms"].as_array().unwrap();
    assert_eq!(bars.len(), terms.len());
    let heights: Vec<f64> = bars
        .iter()
        .map(|b| b.attribute("height").unwrap().parse::<f64>().unwrap())
        .collect();
    let (k, largest) = terms
        .iter()
        .enumerate()
        .map(|(k, t)| (k, number(t, "coefficient_nm").abs()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    for (t, h) in terms.iter().zip(&heights) {
        let ratio = number(t, "coefficient_nm").abs() / largest;
        // Pixels are whole: within a pixel and a half of proportion.
        assert!(
            (h - ratio * heights[k]).abs() <= 1.5,
            "{h} vs {}",
            ratio * heights[k]
        );
    }
    assert!(
        doc.descendants().any(|n| n.has_tag_name("polyline")),
        "the PSD is drawn"
    );
}

/// Maps have their own body limit: a 1.35 MB MetroPro file passes under a 2 MiB map limit
/// while the JSON endpoints keep theirs (1 KiB here), and a map beyond its limit is a 413.
#[tokio::test]
async fn maps_have_their_own_body_limit() {
    use preston::config::ServiceLimits;
    let limits = |map: usize| ServiceLimits {
        max_body_bytes: 1024,
        max_map_bytes: map,
        ..ServiceLimits::default()
    };
    let file = [("content-type", "application/octet-stream")];
    let roomy = super::common::http::app_with(limits(2 << 20));
    let reply = post_with(&roomy, PATH, sample(), &file).await;
    assert_eq!(reply.status, 200, "{}", reply.text());
    let predict = include_str!("../../fixtures/predict_paper_exp2.json");
    assert_eq!(post_json(&roomy, "/v1/predict", predict).await.status, 413);
    let tight = super::common::http::app_with(limits(1 << 20));
    let reply = post_with(&tight, PATH, sample(), &file).await;
    assert_eq!(reply.status, 413, "{}", reply.text());
    assert_eq!(reply.json()["status"], 413);
}

/// `Accept: image/png`: the real sample's heat map, decoded. Its layout is the documented one
/// (`report::heatmap`): the 432-pixel map at scale 1 with its corner at (4, 14); a pixel with
/// no data is transparent; the pixels of the aperture's highest and lowest heights take the
/// ramp's two ends; the title and the scale bar are drawn in black.
#[tokio::test]
async fn the_heat_map_is_a_png_of_the_heights() {
    use preston::report::heatmap::{colour, MAP_ORIGIN};
    let bytes = std::fs::read(crate::common::fixture_path("maps/valid_zygo_dat_file.dat")).unwrap();
    let app = crate::common::http::app();
    let ask = |accept: &'static str| analysed(&app, &bytes, accept);
    let json = ask("application/json").await.json();
    let reply = ask("image/png").await;
    assert_eq!(reply.status, 200);
    assert_eq!(reply.content_type, "image/png");
    let mut reader = png::Decoder::new(std::io::Cursor::new(reply.body))
        .read_info()
        .unwrap();
    let mut rgba = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut rgba).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    let width = info.width as usize;
    let at = |x: usize, y: usize| -> [u8; 4] {
        let i = (y * width + x) * 4;
        [rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]]
    };
    let (x0, y0) = MAP_ORIGIN;
    // The sample's corner pixel (0, 0) holds no data.
    assert_eq!(at(x0, y0)[3], 0, "transparent where there is no data");
    // The CSV lists the aperture's pixels with their heights: find the extremes' pixels.
    let csv = ask("text/csv").await.text();
    let pitch = json["map"]["pixel_mm"].as_f64().unwrap();
    let (cx, cy) = (
        json["alignment"]["centre_x_px"].as_f64().unwrap(),
        json["alignment"]["centre_y_px"].as_f64().unwrap(),
    );
    let mut rows: Vec<(f64, f64, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|c| c.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect();
    rows.sort_by(|a, b| a.2.total_cmp(&b.2));
    for ((x, y, _), end) in [(rows[0], 0.0), (rows[rows.len() - 1], 1.0)] {
        let (column, row) = (
            (cx + x / pitch).round() as usize,
            (cy - y / pitch).round() as usize,
        );
        let [r, g, b] = colour(end);
        assert_eq!(
            at(x0 + column, y0 + row),
            [r, g, b, 255],
            "({column}, {row})"
        );
    }
    let black = |y_range: std::ops::Range<usize>| {
        y_range
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .filter(|&(x, y)| at(x, y) == [0, 0, 0, 255])
            .count()
    };
    assert!(black(0..y0) > 100, "the title");
    let below = y0 + json["map"]["height_px"].as_u64().unwrap() as usize;
    assert!(
        black(below..info.height as usize) > 100,
        "the scale bar and its label"
    );
}

async fn analysed(app: &axum::Router, bytes: &[u8], accept: &str) -> crate::common::http::Reply {
    crate::common::http::post_with(
        app,
        "/v1/maps/analysis",
        bytes.to_vec(),
        &[
            ("content-type", "application/octet-stream"),
            ("accept", accept),
        ],
    )
    .await
}

/// JSON Schema's `integer` includes whole numbers written with a fraction (`12.0`): the
/// term count takes them as the count, and one too many for the ordering is refused naming
/// `zernike.terms`, not as a mismatch of the schema (found by schemathesis: `192.0`).
#[tokio::test]
async fn a_term_count_written_with_a_fraction_is_a_count() {
    let app = app();
    let rows = small_disc(|x, y| 10.0 * (x * x - y * y) + 3.0 * x);
    let body = |terms: &str| {
        format!(
            r#"{{"map": {{"heights_nm": {}, "pixel_mm": 1.0}}, "zernike": {{"terms": {terms}}}}}"#,
            serde_json::to_string(&rows).unwrap()
        )
    };
    let whole = post_json(&app, "/v1/maps/analysis", body("12.0")).await;
    assert_eq!(
        whole.status,
        200,
        "{}",
        String::from_utf8_lossy(&whole.body)
    );
    assert_eq!(
        whole.json()["zernike"]["terms"].as_array().unwrap().len(),
        12
    );
    let too_many = post_json(&app, "/v1/maps/analysis", body("192.0")).await;
    assert_eq!(too_many.status, 422);
    let problem = too_many.json();
    assert_eq!(
        problem["type"], "urn:preston:problem:invalid-input",
        "{problem}"
    );
    assert_eq!(problem["field"], "zernike.terms", "{problem}");
    let fraction = post_json(&app, "/v1/maps/analysis", body("12.5")).await;
    assert_eq!(fraction.status, 422);
    assert_eq!(fraction.json()["field"], "zernike.terms");
}

/// A pixel pitch that makes the map wider than any part (100 m) is refused naming
/// `pixel_mm`, before squared radii overflow (found by schemathesis: 1.12e167 mm was a 500).
#[tokio::test]
async fn a_pixel_wider_than_any_part_is_refused() {
    let app = app();
    let rows = small_disc(|x, y| 10.0 * x * y);
    let rows = serde_json::to_string(&rows).unwrap();
    for pixel in ["1.1198504656359032e+167", "4001.0"] {
        let body =
            format!(r#"{{"map": {{"heights_nm": {rows}, "pixel_mm": 1.0}}, "pixel_mm": {pixel}}}"#);
        let reply = post_json(&app, "/v1/maps/analysis", body).await;
        assert_eq!(
            reply.status,
            422,
            "{}",
            String::from_utf8_lossy(&reply.body)
        );
        let problem = reply.json();
        assert_eq!(problem["field"], "pixel_mm", "{problem}");
        assert!(
            problem["detail"]
                .as_str()
                .unwrap()
                .contains("a map may span 100000 mm at most"),
            "{problem}"
        );
    }
    let fine =
        format!(r#"{{"map": {{"heights_nm": {rows}, "pixel_mm": 1.0}}, "pixel_mm": 3999.0}}"#);
    assert_eq!(post_json(&app, "/v1/maps/analysis", fine).await.status, 200);
}

/// `f` on a disc of 25 × 25 pixels (x, y in the disc's unit coordinates), no data outside.
fn small_disc(f: impl Fn(f64, f64) -> f64) -> Vec<Vec<Option<f64>>> {
    (0..25)
        .map(|r| {
            (0..25)
                .map(|c| {
                    let (x, y) = ((c as f64 - 12.0) / 12.0, (r as f64 - 12.0) / 12.0);
                    (x * x + y * y <= 1.0).then(|| f(x, y))
                })
                .collect()
        })
        .collect()
}
