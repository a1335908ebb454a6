//! Writes the problem an X-Y plan solves, for a peer solver to be given the same one
//! (scripts/peer_bench_raster.py): the request's raster and removal matrix, exactly as
//! `POST /v1/maps/optimize` builds them.
//!
//! ```text
//! cargo run --release --example raster_problem -- REQUEST.json OUT_DIR
//! ```
//!
//! OUT_DIR gets, little-endian: `rows.u32`, `cols.u32`, `vals.f64` (the matrix M's non-zeros
//! on the map's pixels with data: the removal, nm, per second of dwell at each point),
//! `target.f64`, `x.f64`, `y.f64` (each such pixel's height, nm, and place, mm), `lower.f64`
//! (each point's least dwell, s: the axes' floors), `points.f64` (the points, [x, y] mm in path
//! order), `edges.u32` (the smoothing's neighbour pairs), and `meta.json` (sizes, the depth and
//! dwell scales, the smoothing and time weights).

use std::io::Write;

use preston::http::maps::raster::RasterOptimizeRequest;
use preston::optimize::raster::scales;
use preston::usecases::raster_optimize::RasterOptimizeCommand;
use preston::usecases::ComputeLimits;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, request, out] = args.as_slice() else {
        return Err("usage: raster_problem REQUEST.json OUT_DIR".into());
    };
    let request: RasterOptimizeRequest = serde_json::from_slice(&std::fs::read(request)?)?;
    let spec = request
        .spec(&ComputeLimits::default())
        .map_err(|e| format!("{e:?}"))?;
    let (smoothing, time_weight) = (spec.smoothing, spec.time_weight);
    let command = RasterOptimizeCommand::new(spec).map_err(|e| e.to_string())?;
    let problem = command.problem().map_err(|e| e.to_string())?;
    let out = std::path::Path::new(out);
    std::fs::create_dir_all(out)?;
    // The rows on the map's pixels with data, renumbered.
    let rows: Vec<usize> = (0..problem.weights.len())
        .filter(|&k| problem.weights[k] > 0.0)
        .collect();
    let mut row_of = vec![u32::MAX; problem.weights.len()];
    for (i, &k) in rows.iter().enumerate() {
        row_of[k] = i as u32;
    }
    let n = problem.raster.len();
    let (mut ri, mut ci, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    let mut unit = vec![0.0; n];
    for j in 0..n {
        unit[j] = 1.0;
        let column = problem.operator.apply(&unit);
        unit[j] = 0.0;
        for (k, &v) in column.iter().enumerate() {
            if v != 0.0 && row_of[k] != u32::MAX {
                ri.push(row_of[k]);
                ci.push(j as u32);
                vals.push(v);
            }
        }
    }
    let pick = |v: &[f64]| rows.iter().map(|&k| v[k]).collect::<Vec<f64>>();
    write_u32(&out.join("rows.u32"), &ri)?;
    write_u32(&out.join("cols.u32"), &ci)?;
    write_f64(&out.join("vals.f64"), &vals)?;
    write_f64(&out.join("target.f64"), &pick(&problem.target))?;
    write_f64(&out.join("x.f64"), &pick(&problem.xs))?;
    write_f64(&out.join("y.f64"), &pick(&problem.ys))?;
    write_f64(&out.join("lower.f64"), &problem.lower)?;
    let points: Vec<f64> = problem.raster.path().points_mm().concat();
    write_f64(&out.join("points.f64"), &points)?;
    let edges: Vec<u32> = problem
        .edges
        .iter()
        .flat_map(|&(a, b)| [a as u32, b as u32])
        .collect();
    write_u32(&out.join("edges.u32"), &edges)?;
    let (depth, dwell) = scales(&problem.operator, &problem.target, &problem.weights);
    let meta = serde_json::json!({
        "rows": rows.len(),
        "points": n,
        "nonzeros": vals.len(),
        "depth_scale": depth,
        "dwell_scale": dwell,
        "smoothing": smoothing,
        "time_weight": time_weight,
    });
    std::fs::write(out.join("meta.json"), serde_json::to_vec_pretty(&meta)?)?;
    println!("{meta}");
    Ok(())
}

fn write_f64(path: &std::path::Path, v: &[f64]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    v.iter().try_for_each(|x| f.write_all(&x.to_le_bytes()))?;
    f.flush()
}

fn write_u32(path: &std::path::Path, v: &[u32]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    v.iter().try_for_each(|x| f.write_all(&x.to_le_bytes()))?;
    f.flush()
}
