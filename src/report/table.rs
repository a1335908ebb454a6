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

/// Why a CSV export could not be read as columns of numbers. Lines are counted from 1 in the
/// text as sent, comments and blank lines included.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReadError {
    #[error("CSV line {line}: {message}")]
    Csv { line: u64, message: String },
    /// No line names the columns and none starts the numbers; `line` is the first that could
    /// have been a header (a title line has fewer fields than the columns asked for).
    #[error(
        "{}: the CSV needs a header naming the columns {} (units may be written as in `X [mm]`), \
         or rows of numbers in that order",
        match .first { Some((line, text)) => format!("CSV line {line} reads `{text}`"),
                       None => "the CSV has no rows".to_string() },
        .names.join(", ")
    )]
    NoHeader {
        names: Vec<&'static str>,
        first: Option<(u64, String)>,
    },
    /// The `index`-th value of `column` (0-based, counting values) on `line` is not a finite
    /// number.
    #[error("CSV line {line} reads `{row}`: `{text}` in column {column} is not a finite number")]
    NotANumber {
        line: u64,
        row: String,
        column: &'static str,
        index: usize,
        text: String,
    },
}

/// Lines looked at for the header before the numbers must have begun (an export's metadata
/// block: operator, instrument, part, settings).
const PREAMBLE_LINES: usize = 100;

/// A header cell as a column name: lower case, quotes dropped, a unit in brackets or
/// parentheses or after a space or slash joined with `_` (`X [mm]`, `x (mm)`, `X/mm` and
/// `x_mm` all read `x_mm`).
fn column_name(header: &str) -> String {
    let mut name = String::new();
    for c in header.trim().trim_matches('"').trim().chars() {
        match c {
            '[' | ']' | '(' | ')' | '/' | ' ' | '\t' | '_' | '-' => {
                if !name.is_empty() && !name.ends_with('_') {
                    name.push('_');
                }
            }
            c => name.extend(c.to_lowercase()),
        }
    }
    name.trim_end_matches('_').to_string()
}

/// The field separator, from the data's last lines (a title or metadata line above may hold
/// anything): the one most of them hold, `;` or a tab before `,` (numbers may then have
/// decimal commas, so those lines hold a comma too).
fn delimiter(bytes: &[u8]) -> u8 {
    let lines: Vec<&[u8]> = bytes
        .split(|&b| b == b'\n')
        .filter(|l| !l.starts_with(b"#") && !l.trim_ascii().is_empty())
        .collect();
    let data = &lines[lines.len().saturating_sub(5)..];
    let count = |d: u8| data.iter().filter(|l| l.contains(&d)).count();
    let (semicolons, tabs, commas) = (count(b';'), count(b'\t'), count(b','));
    // Lines with decimal commas hold the separator too, so it wins a tie.
    if semicolons > 0 && semicolons >= commas {
        b';'
    } else if tabs > 0 && tabs >= commas {
        b'\t'
    } else {
        b','
    }
}

/// N columns of finite numbers from an instrument's CSV export: optional `#` comment lines;
/// fields separated by `,`, `;` or tabs (with `;` or tabs, numbers with a decimal point or
/// comma); title and metadata lines before an optional header naming `names` (matched without
/// regard to case, quotes or how the unit is written: `X [mm]` is `x_mm`; other columns
/// ignored); then one point per row. Without a header, rows of exactly N numbers are read in
/// that order (more columns are refused: which are which cannot be told). Blank rows are
/// skipped.
pub fn read_columns<const N: usize>(
    bytes: &[u8],
    names: [&'static str; N],
) -> Result<[Vec<f64>; N], ReadError> {
    let delimiter = delimiter(bytes);
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .trim(::csv::Trim::All)
        .flexible(true)
        .from_reader(bytes);
    let parse = |text: &str| {
        let text = if delimiter != b',' {
            text.replace(',', ".")
        } else {
            text.to_string()
        };
        text.parse::<f64>().ok().filter(|v| v.is_finite())
    };
    let row_text = |record: &::csv::StringRecord| {
        let sep = char::from(delimiter).to_string();
        let row = record.iter().collect::<Vec<_>>().join(&sep);
        row.chars().take(120).collect::<String>()
    };
    let mut out: [Vec<f64>; N] = std::array::from_fn(|_| Vec::new());
    let mut columns: Option<[usize; N]> = None;
    // The first line that had as many fields as a header would but did not name the columns.
    let mut not_a_header: Option<(u64, String)> = None;
    let mut preamble = 0;
    for record in reader.records() {
        let record = record.map_err(|e| ReadError::Csv {
            line: e.position().map_or(0, |p| p.line()),
            message: e.to_string(),
        })?;
        let line = record.position().map_or(0, |p| p.line());
        if record.iter().all(str::is_empty) {
            continue;
        }
        let at = match columns {
            Some(at) => at,
            None => {
                let found: Vec<usize> = names
                    .iter()
                    .filter_map(|n| record.iter().position(|h| column_name(h) == *n))
                    .collect();
                if let Ok(found) = <[usize; N]>::try_from(found) {
                    columns = Some(found);
                    continue;
                }
                let numeric =
                    record.len() >= N && record.iter().take(N).all(|v| parse(v).is_some());
                if !numeric {
                    preamble += 1;
                    if record.len() >= N && not_a_header.is_none() {
                        not_a_header = Some((line, row_text(&record)));
                    }
                    if preamble >= PREAMBLE_LINES {
                        break;
                    }
                    continue;
                }
                // Numbers with no header: a line before them that could have been one was not;
                // and with more columns than asked for, which are which cannot be told (a
                // point number first would be read as x).
                if not_a_header.is_some() {
                    break;
                }
                if record.len() > N {
                    return Err(ReadError::NoHeader {
                        names: names.to_vec(),
                        first: Some((line, row_text(&record))),
                    });
                }
                *columns.insert(std::array::from_fn(|k| k))
            }
        };
        let index = out[0].len();
        for k in 0..N {
            let text = record.get(at[k]).unwrap_or("");
            let value = parse(text).ok_or_else(|| ReadError::NotANumber {
                line,
                row: row_text(&record),
                column: names[k],
                index,
                text: text.to_string(),
            })?;
            out[k].push(value);
        }
    }
    if columns.is_none() {
        return Err(ReadError::NoHeader {
            names: names.to_vec(),
            first: not_a_header,
        });
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
                line: 3,
                row: "3,inf".into(),
                column: "z_mm",
                index: 1,
                text: "inf".into()
            })
        );
        let error = super::read_columns(b"a,b\n1,2\n", names).unwrap_err();
        assert_eq!(
            error,
            super::ReadError::NoHeader {
                names: vec!["x_mm", "z_mm"],
                first: Some((1, "a,b".into()))
            }
        );
        assert!(
            error.to_string().starts_with("CSV line 1 reads `a,b`"),
            "{error}"
        );
        // The line counts comments and blank lines: what an editor shows.
        let error = super::read_columns(b"# export\n\nx_mm,z_mm\n1,2\n1,2x\n", names);
        assert!(
            matches!(error, Err(super::ReadError::NotANumber { line: 5, .. })),
            "{error:?}"
        );
    }

    /// The exports probes write: a point number and unit-suffixed headers, a title line, `;`
    /// with decimal commas, tabs.
    #[test]
    fn reads_common_probe_exports() {
        let names = ["x_mm", "z_mm"];
        let expected = (vec![-20.0, 0.5], vec![0.6678, 0.0]);
        for text in [
            "Point,X [mm],Z [mm]\n1,-20,0.6678\n2,0.5,0\n",
            "Probe trace SN-0042\nx_mm,z_mm\n-20,0.6678\n0.5,0\n",
            "Trace 7\nX (mm);Z (mm)\n-20;0,6678\n0,5;0\n",
            "-20;0,6678\n0,5;0\n",
            "x/mm\tz/mm\n-20\t0.6678\n0.5\t0\n",
            "\"X [mm]\",\"Z [mm]\"\n-20,0.6678\n0.5,0\n",
        ] {
            let [x, z] = super::read_columns(text.as_bytes(), names)
                .unwrap_or_else(|e| panic!("{text:?}: {e}"));
            assert_eq!((x, z), expected, "{text:?}");
        }
        // A metadata line with a `;` above comma-separated data does not decide the separator.
        let [x, z] = super::read_columns(
            "Operator: Smith; cell 3\nx_mm,z_mm\n-20,0.6678\n0.5,0\n".as_bytes(),
            names,
        )
        .unwrap();
        assert_eq!((x, z), expected);
        // Tabs with decimal commas.
        let [x, z] =
            super::read_columns("X [mm]\tZ [mm]\n-20\t0,6678\n0,5\t0\n".as_bytes(), names).unwrap();
        assert_eq!((x, z), expected);
        // Headerless rows with a point number first are refused, not read as x.
        let error = super::read_columns(b"Trace 7\n1,-20,0.6678\n2,0.5,0\n", names).unwrap_err();
        assert!(
            error.to_string().contains("line 2 reads `1,-20,0.6678`"),
            "{error}"
        );
        // A header in other units is not read as millimetres.
        let error = super::read_columns(b"X [um],Z [um]\n1,2\n", names).unwrap_err();
        assert!(error.to_string().contains("`X [um],Z [um]`"), "{error}");
    }
}
