//! Invariants every render keeps, checked on every scene in `scenes/`: the per-term images sum
//! to the beauty image, the thread count changes no bit, and nothing is NaN.

use lancer_tests::{load_file, render, scene_files};

#[test]
fn per_term_images_sum_to_beauty_exactly() {
    for path in scene_files() {
        let frame = render(&load_file(&path), Some(80), 2);
        let beauty = frame.beauty();
        // Sum the layers here, independently of Frame::beauty, in layer order.
        for (i, b) in beauty.iter().enumerate() {
            let mut sum = glam::Vec3::ZERO;
            for layer in &frame.layers {
                sum += layer.pixels[i];
            }
            assert_eq!(sum, *b, "{}: pixel {i}", path.display());
        }
        assert!(
            frame.layers.iter().all(|l| l.pixels.iter().all(|p| p.is_finite())),
            "{}: a NaN or infinity",
            path.display()
        );
    }
}

#[test]
fn the_thread_count_changes_no_bit() {
    for path in scene_files() {
        let loaded = load_file(&path);
        let one = render(&loaded, Some(72), 1);
        let two = render(&loaded, Some(72), 2);
        let three = render(&loaded, Some(72), 3);
        assert!(one == two && two == three, "{}: renders differ across thread counts", path.display());
    }
}

#[test]
fn the_terms_list_decides_which_images_exist() {
    let path = lancer_tests::root().join("scenes/showcase.toml");
    let src = std::fs::read_to_string(&path).unwrap();
    let only = src.replace(
        "terms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\", \"refraction\"]",
        "terms = [\"diffuse\", \"ambient\"]",
    );
    assert_ne!(src, only, "the showcase lists the five terms");
    let full = render(&lancer_tests::load(&src), Some(64), 2);
    let two = render(&lancer_tests::load(&only), Some(64), 2);
    let names: Vec<&str> = two.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["diffuse", "ambient", "background"]);
    // Camera-ray ambient and diffuse do not depend on which other terms run.
    assert!(full.layer("ambient") == two.layer("ambient"), "ambient depends on the other terms");
    assert!(full.layer("diffuse") == two.layer("diffuse"), "diffuse depends on the other terms");
    assert_ne!(full.beauty(), two.beauty());
}
