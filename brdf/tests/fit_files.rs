//! Fit files are input: every edit that breaks an invariant the evaluators
//! index by is refused on load with an error that names it.

use brdf::{fit_brdf, BlinnPhong, BrdfFitSettings, FittedBrdf, Reduction};
use serde_json::{json, Value};

fn fit_json() -> Value {
    let m = BlinnPhong {
        kd: [0.2; 3],
        ks: [0.3; 3],
        exponent: 12.0,
    };
    let s = BrdfFitSettings::default()
        .with_reduction(Reduction::default().with_resolution(16, 16))
        .with_baselines(false);
    let (f, _) = fit_brdf(&m, &s).unwrap();
    serde_json::to_value(&f).unwrap()
}

/// Applies `edit` and returns the load error's text.
fn refused(edit: impl Fn(&mut Value)) -> String {
    let mut v = fit_json();
    edit(&mut v);
    match serde_json::from_value::<FittedBrdf>(v) {
        Ok(f) => panic!("accepted an edited fit: {f:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_valid_fit_round_trips() {
    let v = fit_json();
    let f: FittedBrdf = serde_json::from_value(v.clone()).unwrap();
    f.validate().unwrap();
    assert_eq!(serde_json::to_value(&f).unwrap(), v);
}

#[test]
fn edited_fit_files_are_refused_with_the_reason() {
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "two channels",
            Box::new(|v| {
                v["channels"].as_array_mut().unwrap().pop();
            }),
            "2 channels",
        ),
        (
            "four channels",
            Box::new(|v| {
                let c = v["channels"][0].clone();
                v["channels"].as_array_mut().unwrap().push(c);
            }),
            "4 channels",
        ),
        (
            "a 3-D channel in a 2-D fit",
            Box::new(|v| {
                v["channels"][1]["basis"]["domain"] =
                    json!({"lower": [0.0, 0.0, 0.0], "upper": [1.0, 1.0, 1.0]});
            }),
            "3 coordinates",
        ),
        (
            "a denominator of zeros",
            Box::new(|v| {
                let n = v["channels"][0]["denominator"].as_array().unwrap().len();
                v["channels"][0]["denominator"] = json!(vec![0.0; n]);
            }),
            "identically zero",
        ),
        (
            "a huge basis",
            Box::new(|v| v["channels"][0]["basis"]["len"] = json!(150_000_000u64)),
            "at most 100000",
        ),
        (
            "an elevation cut beyond the horizon",
            Box::new(|v| v["reduction"]["max_elevation_deg"] = json!(500.0)),
            "max_elevation_deg",
        ),
        (
            "a negative grazing cut",
            Box::new(|v| v["reduction"]["max_theta_d_deg"] = json!(-5.0)),
            "max_theta_d_deg",
        ),
        (
            "a huge grid",
            Box::new(|v| v["reduction"]["n_theta_h"] = json!(100_000)),
            "n_theta_h",
        ),
        (
            "a coefficient that is not a number (null)",
            Box::new(|v| v["channels"][2]["numerator"][0] = json!(1e308 * 10.0)),
            "",
        ),
    ];
    for (what, edit, expected) in cases {
        let e = refused(edit);
        assert!(e.contains(expected), "{what}: {e}");
    }
}
