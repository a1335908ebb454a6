//! The sanity table of docs/MODEL.md (r_m 50 mm, r_t 10 mm, K 1e-13, 10 kPa; nm/min), to 4 decimals.

use crate::common;

use preston::physics::removal_rate_nm_per_min;

#[test]
fn reproduces_the_design_sanity_table_to_four_decimals() {
    // (workpiece_rpm, tool_rpm, r1, [R at r = 2, 20, 25 mm])
    let table = [
        (-10.0, 200.0, 5.0, [6.5635, 0.0, 0.0]),
        (-10.0, 200.0, 20.0, [0.0, 1.0757, 1.2418]),
        (150.0, 150.0, 5.0, [4.7124, 0.0, 0.0]),
        (150.0, 150.0, 20.0, [0.0, 3.0322, 2.3386]),
    ];
    for (w, t, r1, row) in table {
        let p = common::paper_process(w, t);
        for (r, want) in [2.0, 20.0, 25.0].into_iter().zip(row) {
            let got = removal_rate_nm_per_min(&p, r, r1);
            // Rounded to 4 decimals, the table's values are reproduced exactly.
            assert!(
                (got - want).abs() <= 0.5e-4,
                "w {w} t {t} r1 {r1} r {r}: {got:.6} vs {want}"
            );
        }
    }
}
