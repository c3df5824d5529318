//! Fit a CSV of samples (coordinates, then the value) within a relative
//! tolerance, print the report and evaluate the fit:
//!
//! ```sh
//! cargo run --release -p rational-core --example fit_csv -- data.csv 0.01
//! ```
//!
//! Without arguments it fits Runge's function `1 / (1 + 25 x^2)` at 2,000
//! points within 1%.

use rational_core::{fit, FitReport, FitSettings, IntervalData};
use std::error::Error;

/// Sample coordinates (`dim` per sample, one after the other) and values.
type Samples = (usize, Vec<f64>, Vec<f64>);

/// Parses `x_1, ..., x_d, value` rows with the `csv` crate (a first row
/// that is not numbers is a header).
fn read_csv(text: &str) -> Result<Samples, Box<dyn Error>> {
    let (mut dim, mut points, mut values) = (0, Vec::new(), Vec::new());
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    for (no, record) in reader.records().enumerate() {
        let record = record?;
        let Ok(row) = record
            .iter()
            .map(str::parse::<f64>)
            .collect::<Result<Vec<_>, _>>()
        else {
            if no == 0 {
                continue; // a header
            }
            return Err(format!("row {}: not a row of numbers", no + 1).into());
        };
        if row.len() < 2 || (dim != 0 && row.len() != dim + 1) {
            return Err(format!("row {}: {} fields", no + 1, row.len()).into());
        }
        dim = row.len() - 1;
        points.extend_from_slice(&row[..dim]);
        values.push(row[dim]);
    }
    Ok((dim, points, values))
}

/// Fits `values` at `points` within `rel_tol`.
fn fit_values(
    dim: usize,
    points: Vec<f64>,
    values: Vec<f64>,
    rel_tol: f64,
) -> Result<FitReport, Box<dyn Error>> {
    let data = IntervalData::from_values_relative(dim, points, values, rel_tol)?;
    Ok(fit(&data, &FitSettings::default())?)
}

fn runge() -> Samples {
    let x: Vec<f64> = (0..2000).map(|i| -1.0 + 2.0 * i as f64 / 1999.0).collect();
    let v = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
    (1, x, v)
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (dim, points, values) = match args.first() {
        Some(path) => read_csv(&std::fs::read_to_string(path)?)?,
        None => runge(),
    };
    let rel_tol = args.get(1).map_or(Ok(0.01), |t| t.parse())?;
    let first = points[..dim].to_vec();
    let report = fit_values(dim, points, values, rel_tol)?;
    println!("{report}");
    println!("r({first:?}) = {}", report.function.eval(&first));
    Ok(())
}

#[test]
fn runge_within_one_percent_takes_four_coefficients() {
    let (dim, points, values) = runge();
    let report = fit_values(dim, points, values, 0.01).unwrap();
    assert!(report.verification.satisfied);
    assert_eq!(report.n_p + report.n_q, 4);
}

#[test]
fn a_csv_with_a_header_is_read() {
    let (dim, points, values) = read_csv("x,y,value\n0,0,1\n0.5,1,2\n").unwrap();
    assert_eq!(
        (dim, points, values),
        (2, vec![0.0, 0.0, 0.5, 1.0], vec![1.0, 2.0])
    );
    assert!(read_csv("1,2\n3\n").is_err());
}
