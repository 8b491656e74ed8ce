//! Point files: CSV with a header naming the axes (any order), one point per row.
//! Errors name the row (1-based, counting the header as row 1) and the column.

use crate::error::{Error, Result};
use std::path::Path;

/// Points read from a CSV file, reordered to the requested axis order.
#[derive(Clone, Debug)]
pub struct Points {
    /// Column names as they appear in the file.
    pub header: Vec<String>,
    /// The raw cells of every row, to be repeated verbatim in the output.
    pub raw: Vec<Vec<String>>,
    /// Coordinates in the requested axis order.
    pub coords: Vec<Vec<f64>>,
}

/// Refuse point files with more rows than this before parsing them all.
pub const MAX_POINTS: usize = 50_000_000;

/// `text` without a leading UTF-8 byte-order mark (U+FEFF), which spreadsheet programs write
/// at the start of a CSV file and which is not part of the first column's name.
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Reads `path`, whose header must name exactly the `axes` (any order). Each value must be a
/// finite number inside `ranges[axis]`.
pub fn read_points(path: &Path, axes: &[String], ranges: &[(f64, f64)]) -> Result<Points> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_points(&text, axes, ranges).map_err(|m| Error::file(path, m))
}

pub fn parse_points(
    text: &str,
    axes: &[String],
    ranges: &[(f64, f64)],
) -> std::result::Result<Points, String> {
    let text = strip_bom(text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, head)) = lines.next() else {
        return Err(format!(
            "empty file; expected a header naming the axes {}",
            axes.join(",")
        ));
    };
    let header: Vec<String> = head.split(',').map(|s| s.trim().to_string()).collect();
    let mut index = vec![usize::MAX; axes.len()];
    for (c, name) in header.iter().enumerate() {
        match axes.iter().position(|a| a == name) {
            Some(a) if index[a] == usize::MAX => index[a] = c,
            Some(_) => return Err(format!("column '{name}' appears twice in the header")),
            None => {
                return Err(format!(
                    "unknown column '{name}' in the header; the model's axes are {} (any order)",
                    axes.join(",")
                ))
            }
        }
    }
    if let Some(missing) = axes.iter().zip(&index).find(|(_, &i)| i == usize::MAX) {
        return Err(format!(
            "the header lacks the axis '{}'; expected columns {}",
            missing.0,
            axes.join(",")
        ));
    }
    let mut raw = Vec::new();
    let mut coords = Vec::new();
    for (line_no, line) in lines {
        if raw.len() >= MAX_POINTS {
            return Err(format!("more than {MAX_POINTS} points; split the file"));
        }
        let row = line_no + 1;
        let cells: Vec<String> = line.split(',').map(|s| s.trim().to_string()).collect();
        if cells.len() != header.len() {
            return Err(format!(
                "row {row}: {} values for {} columns",
                cells.len(),
                header.len()
            ));
        }
        let mut x = vec![0.0; axes.len()];
        for (a, &c) in index.iter().enumerate() {
            let v: f64 = cells[c].parse().map_err(|_| {
                format!(
                    "row {row}, column '{}': '{}' is not a number",
                    axes[a], cells[c]
                )
            })?;
            if !v.is_finite() {
                return Err(format!(
                    "row {row}, column '{}': {v} is not a finite number",
                    axes[a]
                ));
            }
            let (lo, hi) = ranges[a];
            if v < lo || v > hi {
                return Err(format!(
                    "row {row}, column '{}': {v} is outside the domain [{lo}, {hi}]",
                    axes[a]
                ));
            }
            x[a] = v;
        }
        raw.push(cells);
        coords.push(x);
    }
    if coords.is_empty() {
        return Err(format!(
            "no points: the header ({}) is not followed by any row; add one point per row below it",
            header.join(",")
        ));
    }
    Ok(Points {
        header,
        raw,
        coords,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes() -> (Vec<String>, Vec<(f64, f64)>) {
        (vec!["r".into(), "mu".into()], vec![(0.0, 1.0), (0.0, 1.0)])
    }

    #[test]
    fn any_column_order() {
        let (a, r) = axes();
        let p = parse_points("mu,r\n0.25,0.5\n", &a, &r).unwrap();
        assert_eq!(p.coords, vec![vec![0.5, 0.25]]);
    }

    #[test]
    fn a_leading_byte_order_mark_is_not_part_of_the_header() {
        let (a, r) = axes();
        let p = parse_points("\u{feff}mu,r\n0.25,0.5\n", &a, &r).unwrap();
        assert_eq!(p.header, vec!["mu", "r"]);
        assert_eq!(p.coords, vec![vec![0.5, 0.25]]);
    }

    #[test]
    fn errors_name_row_and_column() {
        let (a, r) = axes();
        let e = parse_points("r,mu\n0.5,0.5\n0.5,abc\n", &a, &r).unwrap_err();
        assert!(e.contains("row 3") && e.contains("'mu'"), "{e}");
        let e = parse_points("r,mu\n0.5,NaN\n", &a, &r).unwrap_err();
        assert!(e.contains("row 2") && e.contains("finite"), "{e}");
        let e = parse_points("r,mu\n1.5,0.5\n", &a, &r).unwrap_err();
        assert!(e.contains("outside"), "{e}");
        let e = parse_points("r\n0.5\n", &a, &r).unwrap_err();
        assert!(e.contains("lacks the axis 'mu'"), "{e}");
        let e = parse_points("r,mu,x\n0.5,0.5,1\n", &a, &r).unwrap_err();
        assert!(e.contains("unknown column 'x'"), "{e}");
        let e = parse_points("r,mu\n\n", &a, &r).unwrap_err();
        assert!(
            e.contains("no points") && e.contains("add one point per row"),
            "{e}"
        );
    }
}
