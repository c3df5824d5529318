use super::*;
use crate::TableSettings;
use brdf::{Brdf, Vec3};

/// Blinn-Phong times a factor of the incident elevation alone: not
/// reciprocal, as measured tables are not quite.
struct Skewed;

impl Brdf for Skewed {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let lobe = brdf::BlinnPhong {
            kd: [0.3; 3],
            ks: [0.5; 3],
            exponent: 40.0,
        };
        lobe.eval(wi, wo).map(|v| v * (1.0 + 0.8 * wi[2]))
    }

    fn name(&self) -> String {
        "skewed".into()
    }
}

/// [`Skewed`]'s table at 6 views and 30 x 24 cells, small enough for a test.
fn skewed_table() -> CdfTable {
    let settings = TableSettings::default()
        .with_views(6)
        .unwrap()
        .with_cells(30, 24)
        .unwrap();
    CdfTable::new(&Skewed, settings).unwrap()
}

#[test]
fn azimuth_intervals_are_reciprocal_though_the_table_is_not() {
    let table = skewed_table();
    let (a, b) = (table.view(1), table.view(4));
    let mut table_differs = false;
    for q in 1..8 {
        let tau = f64::from(q) / 8.0;
        let (x, swapped) = ([a, b, tau], [b, a, tau]);
        let fitted = interval_at(&table, Component::Phi, &x, 0.05, 1e-3);
        let fitted_swapped = interval_at(&table, Component::Phi, &swapped, 0.05, 1e-3);
        assert_eq!(fitted, fitted_swapped, "tau {tau}");
        let own = tabulated_interval(&table, Component::Phi, &x, 0.05, 1e-3);
        let own_swapped = tabulated_interval(&table, Component::Phi, &swapped, 0.05, 1e-3);
        table_differs |= (own.2 - own_swapped.2).abs() > 1e-3;
    }
    assert!(table_differs, "the test material should not be reciprocal");
}

/// The refinement's verdicts: a non-monotone candidate gets rows of
/// its split's length (or is refused once the rounds are spent, which
/// is recorded for the error), a fitted monotone one is accepted.
#[test]
fn non_monotone_candidates_get_rows_then_a_refusal() {
    let table = skewed_table();
    let s = CdfFitSettings::default();
    let c = Component::Theta;
    let checks = check_points(&table, c, &s);
    let a = assemble(&table, c, &sample_points(&table, c, &s), 0.05, 1e-3).unwrap();
    let refiner = MonotoneRefiner {
        table: &table,
        c,
        delta: 0.05,
        min_half: 1e-3,
        at_samples: &a.monotone,
        checks: &checks,
        max_rounds: 2,
        refused: Mutex::new(None),
    };
    // The rational part `1 - 40 mu` (graded monomials 1, theta_v, mu,
    // ...): it falls in mu.
    let basis = Basis::new(
        rational_core::BasisFamily::Monomial,
        domain(c, table.settings().max_view()).unwrap(),
        6,
    )
    .unwrap();
    let falling =
        RationalFunction::new(basis, vec![1.0, 0.0, -40.0, 0.0, 0.0, 0.0], vec![1.0]).unwrap();
    let Refinement::AddRows(rows) = refiner.refine(&falling, 0) else {
        panic!("a falling map needs rows")
    };
    assert!(!rows.is_empty());
    assert!(rows.iter().all(|r| r.len() == 7));
    assert!(matches!(
        refiner.refine(&falling, 2),
        Refinement::Reject { .. }
    ));
    let refused = refiner.refused.lock().unwrap().clone().unwrap();
    assert!(refused.0 < 0.0 && refused.2 == 2, "{refused:?}");
    // A fit accepted by the search is monotone on the whole grid.
    let found = search_budget(
        &a.data,
        &refiner,
        &s.engine
            .clone()
            .with_domain(domain(c, table.settings().max_view()).unwrap()),
        2,
        64,
        &mut Vec::new(),
    )
    .unwrap()
    .expect("a monotone fit");
    let inv = InverseCdf::new(c, found.function.clone()).unwrap();
    assert!(check_monotone(&inv, &checks).2.is_empty());
    assert_eq!(refiner.refine(&found.function, 0), Refinement::Accept);
}
