//! CSV tables: one header line with units, then one row per sample.

/// `header` names each column (with its unit); `columns` are equally long.
pub fn csv(header: &[String], columns: &[&[f64]]) -> String {
    let rows = columns.first().map_or(0, |c| c.len());
    debug_assert!(columns.iter().all(|c| c.len() == rows));
    let mut out = header.join(",");
    out.push('\n');
    for i in 0..rows {
        let row: Vec<String> = columns.iter().map(|c| c[i].to_string()).collect();
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn renders_header_and_rows() {
        let csv = super::csv(
            &["radius_mm".into(), "removal_nm".into()],
            &[&[0.0, 0.5], &[1.25, 3.0]],
        );
        assert_eq!(csv, "radius_mm,removal_nm\n0,1.25\n0.5,3\n");
    }
}
