//! CSV tables: one header line with units, then one row per sample; and the reverse, two
//! named columns of numbers read from an instrument's export.

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

/// Why a CSV export could not be read as two columns of numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadError {
    #[error("CSV: {0}")]
    Csv(String),
    #[error(
        "the CSV starts with a header naming the columns {} (or with a row of numbers in that \
         order)",
        .0.join(", ")
    )]
    NoHeader(Vec<&'static str>),
    /// The `index`-th value of `column` (0-based, counting values) on `row` (1-based, counting
    /// lines read) is not a finite number.
    #[error("CSV row {row}: `{text}` is not a finite number")]
    NotANumber {
        row: usize,
        column: &'static str,
        index: usize,
        text: String,
    },
}

/// N columns of finite numbers from CSV text: optional `#` comment lines, an optional header
/// naming `names` (matched without regard to case or quotes; other columns ignored), then one
/// point per row; without a header the first N columns are read. Blank rows are skipped.
pub fn read_columns<const N: usize>(
    bytes: &[u8],
    names: [&'static str; N],
) -> Result<[Vec<f64>; N], ReadError> {
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .comment(Some(b'#'))
        .trim(::csv::Trim::All)
        .flexible(true)
        .from_reader(bytes);
    let mut out: [Vec<f64>; N] = std::array::from_fn(|_| Vec::new());
    let mut columns: Option<[usize; N]> = None;
    for (line, record) in reader.records().enumerate() {
        let record = record.map_err(|e| ReadError::Csv(e.to_string()))?;
        if record.iter().all(str::is_empty) {
            continue;
        }
        let at = match columns {
            Some(at) => at,
            None => {
                let find = |name: &str| {
                    let name_of = |h: &str| h.trim_matches('"').eq_ignore_ascii_case(name);
                    record.iter().position(name_of)
                };
                let found: Vec<usize> = names.iter().filter_map(|n| find(n)).collect();
                if let Ok(found) = <[usize; N]>::try_from(found) {
                    columns = Some(found);
                    continue;
                }
                if record.get(0).is_none_or(|v| v.parse::<f64>().is_err()) {
                    return Err(ReadError::NoHeader(names.to_vec()));
                }
                *columns.insert(std::array::from_fn(|k| k))
            }
        };
        let index = out[0].len();
        for k in 0..N {
            let text = record.get(at[k]).unwrap_or("");
            let value = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| ReadError::NotANumber {
                    row: line + 1,
                    column: names[k],
                    index,
                    text: text.to_string(),
                })?;
            out[k].push(value);
        }
    }
    Ok(out)
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

    #[test]
    fn reads_named_columns_in_any_order_or_the_first_two() {
        let names = ["x_mm", "z_mm"];
        let text = "# probe export\nZ_MM,t,\"x_mm\"\n1.5,0,-2\n\n2.5,1,3e1\n";
        let [x, z] = super::read_columns(text.as_bytes(), names).unwrap();
        assert_eq!((x, z), (vec![-2.0, 30.0], vec![1.5, 2.5]));
        let [x, z] = super::read_columns(b"1,2\n3,4\n", names).unwrap();
        assert_eq!((x, z), (vec![1.0, 3.0], vec![2.0, 4.0]));
    }

    #[test]
    fn names_the_value_that_is_not_a_number() {
        let names = ["x_mm", "z_mm"];
        assert_eq!(
            super::read_columns(b"x_mm,z_mm\n1,2\n3,inf\n", names),
            Err(super::ReadError::NotANumber {
                row: 3,
                column: "z_mm",
                index: 1,
                text: "inf".into()
            })
        );
        assert_eq!(
            super::read_columns(b"a,b\n1,2\n", names),
            Err(super::ReadError::NoHeader(vec!["x_mm", "z_mm"]))
        );
    }
}
