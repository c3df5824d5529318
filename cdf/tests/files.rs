//! CDF files are input: edited table settings and inverse CDFs are refused
//! on load with the reason, before anything is allocated.

use cdf::TableSettings;
use serde_json::json;

fn settings_json() -> serde_json::Value {
    serde_json::to_value(TableSettings::default()).unwrap()
}

fn refused(edit: impl Fn(&mut serde_json::Value)) -> String {
    let mut v = settings_json();
    edit(&mut v);
    match serde_json::from_value::<TableSettings>(v) {
        Ok(s) => panic!("accepted edited table settings: {s:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn table_settings_round_trip_and_edits_are_refused() {
    let s: TableSettings = serde_json::from_value(settings_json()).unwrap();
    assert_eq!(s, TableSettings::default());
    for (edit, expected) in [
        (json!({"views": 0}), "views"),
        (json!({"views": 1_000_000}), "views"),
        (json!({"theta_cells": 2}), "theta cells"),
        (json!({"max_view": 2.0}), "max view"),
        (json!({"supersample": 0}), "supersample"),
        (
            json!({"views": 4096, "theta_cells": 8192, "phi_cells": 8192}),
            "GiB",
        ),
    ] {
        let e = refused(|v| {
            for (k, x) in edit.as_object().unwrap() {
                v[k] = x.clone();
            }
        });
        assert!(e.contains(expected), "{edit}: {e}");
    }
}
