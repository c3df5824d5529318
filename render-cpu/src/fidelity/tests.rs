//! Tests of the validation renders and their comparison.

use super::*;

#[test]
fn side_by_side_puts_reference_candidate_and_difference_in_a_row() {
    let a = Image::new(2, 1, vec![[0.5; 3], [0.0; 3]]);
    let b = Image::new(2, 1, vec![[0.5; 3], [0.2, 0.0, 0.0]]);
    let (w, h, rgb) = side_by_side(&a, &b, 5.0).unwrap();
    assert_eq!((w, h, rgb.len()), (6, 1, 18));
    assert_eq!(&rgb[..6], &a.to_srgb8(1.0)[..]);
    assert_eq!(&rgb[6..12], &b.to_srgb8(1.0)[..]);
    // Equal pixels are black in the difference, different ones not.
    assert_eq!(&rgb[12..15], &[0, 0, 0]);
    assert!(rgb[15..18].iter().any(|&v| v > 0));
    assert!(side_by_side(&a, &Image::new(1, 1, vec![[0.5; 3]]), 5.0).is_err());
}

#[test]
fn non_finite_pixels_are_counted_and_do_not_poison_the_mean() {
    let a = Image::new(2, 2, vec![[0.5; 3]; 4]);
    let mut pixels = vec![[0.5; 3]; 4];
    pixels[1] = [f32::INFINITY, 0.5, 0.5];
    pixels[2] = [f32::NAN; 3];
    let e = scene_error(&a, &Image::new(2, 2, pixels), &[PixelKind::Interior; 4]).unwrap();
    assert_eq!(e.non_finite_pixels, 2);
    assert!(e.mean_de.is_finite() && e.mean_de > 10.0, "{e:?}");
    let same = scene_error(&a, &a, &[PixelKind::Interior; 4]).unwrap();
    assert_eq!((same.non_finite_pixels, same.mean_de), (0, 0.0));
}

#[test]
fn candidates_are_replayed_from_the_recorded_renders() {
    let ggx = |kd, alpha| -> Arc<dyn Brdf> {
        Arc::new(brdf::CookTorranceGgx {
            kd,
            f0: [0.05; 3],
            alpha,
        })
    };
    let table = ggx([0.3, 0.4, 0.1], 0.2);
    let settings = ValidationSettings {
        size: 24,
        lights_spp: 1,
        sky_spp: 16,
        seed: 3,
    };
    let v = Validator::new(table.clone(), settings).unwrap();
    assert!(v.recorded.iter().all(Option::is_some));
    // The table replayed is the table rendered.
    for s in v.measure(table).unwrap().scenes {
        assert!(s.mean_de < 1e-3, "{s:?}");
    }
    let other = ggx([0.1, 0.1, 0.5], 0.08);
    // A fit evaluated in f32, whose batched and single evaluations may
    // round differently: each sample keeps the render's path.
    let reduction = brdf::Reduction::default()
        .with_kind(brdf::ReductionKind::Full3d)
        .with_resolution(6, 6)
        .with_phi_resolution(6)
        .whole_hemisphere();
    let fit_settings = brdf::BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_baselines(false);
    let broad = ggx([0.1, 0.1, 0.5], 0.3);
    let (fitted, _) = brdf::fit_brdf(broad.as_ref(), &fit_settings).unwrap();
    let fitted = crate::FitInDomain::new(fitted);
    assert!(fitted.uses_f32());
    let fitted: Arc<dyn Brdf> = Arc::new(fitted);
    for candidate in [other, fitted] {
        let replayed = v.measure(candidate.clone()).unwrap();
        assert!(replayed.scenes.iter().all(|s| s.mean_de > 1.0));
        let rendered = v.render_all(&candidate, settings.seed);
        for (a, b) in rendered.iter().zip(&replayed.images) {
            for (p, q) in a.pixels.iter().zip(&b.pixels) {
                for c in 0..3 {
                    // Only the order of the sums differs.
                    let d = (p[c] - q[c]).abs() / p[c].abs().max(1e-3);
                    assert!(d < 1e-6, "{p:?} against {q:?}");
                }
            }
        }
    }
}

#[test]
fn the_error_counts_the_spheres_pixels_only() {
    // Pixels off the sphere, equal in both images, do not dilute its
    // error.
    let a = Image::new(2, 2, vec![[0.5; 3], [0.5; 3], [0.3; 3], [0.3; 3]]);
    let b = Image::new(2, 2, vec![[0.5; 3], [0.5; 3], [0.2; 3], [0.3; 3]]);
    use PixelKind::{Interior, Off, Silhouette};
    let one = scene_error(&a, &b, &[Off, Off, Silhouette, Off]).unwrap();
    let all = scene_error(&a, &b, &[Interior; 4]).unwrap();
    assert!(one.mean_de > 5.0, "{one:?}");
    assert!(
        (one.silhouette_mean_de - one.mean_de).abs() < 1e-12,
        "{one:?}"
    );
    assert!((all.mean_de * 4.0 - one.mean_de).abs() < 1e-9, "{all:?}");
    assert!(all.silhouette_mean_de.abs() < 1e-12, "{all:?}");
    assert!(scene_error(&a, &b, &[Interior; 3]).is_err());
    // Both scenes: the sphere covers about 64% of the frame, its
    // silhouette (beyond 70 degrees) about 12% of the sphere.
    let settings = ValidationSettings {
        size: 48,
        ..RENDER_CHECK
    };
    for scene in validation_scenes(settings).unwrap() {
        let mask = object_mask(&scene);
        let count = |k: PixelKind| mask.iter().filter(|&&m| m == k).count() as f64;
        let sphere = count(Interior) + count(Silhouette);
        let share = sphere / mask.len() as f64;
        assert!((share - 0.64).abs() < 0.03, "{share}");
        let rim = count(Silhouette) / sphere;
        assert!((rim - 0.12).abs() < 0.03, "{rim}");
    }
}
