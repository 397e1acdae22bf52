//! `lancer sheet` as a teacher runs it: a sheet file to a PNG and to a page, each cell the very
//! image `lancer render` writes with the same changes, and a mistaken sheet refused with its
//! place and no file written.

use std::path::PathBuf;

mod common;
use common::{files, lancer, stderr};

use base64::Engine as _;

fn repo(rel: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", rel].iter().collect();
    p.canonicalize().unwrap().display().to_string()
}

const SHEET: &str = r#"
title = "Blinn against Phong"
scene = "SCENE"

[[columns]]
label = "phong"

[[columns]]
label = "blinn, soft shadows"
terms = "ambient,diffuse,specular:blinn"
shadows = "soft:samples=4"

[[rows]]
label = "specular"
image = "specular"

[[rows]]
label = "beauty"
"#;

/// Where `small` stands in `big`, pixel for pixel, if anywhere.
fn find(big: &image::RgbImage, small: &image::RgbImage) -> Option<(u32, u32)> {
    let (w, h) = small.dimensions();
    (0..=big.height() - h)
        .flat_map(|y| (0..=big.width() - w).map(move |x| (x, y)))
        .find(|&(x, y)| (0..h).all(|j| (0..w).all(|i| big.get_pixel(x + i, y + j) == small.get_pixel(i, j))))
}

#[test]
fn each_cell_of_the_sheet_is_the_image_lancer_render_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SHEET.replace("SCENE", &repo("scenes/glass.toml"))).unwrap();
    let o = lancer(d, &["sheet", "s.toml", "--width", "640", "-o", "s.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 x 2 cells") && stderr(&o).contains("(2 renders)"), "{}", stderr(&o));
    let o = lancer(d, &["sheet", "s.toml", "--width", "640", "-o", "s.html", "-q"]);
    assert!(o.status.success() && o.stderr.is_empty(), "{}", stderr(&o));
    assert_eq!(files(d), ["s.html", "s.png", "s.toml"], "no temporary file is left behind");

    // The page's cells, row by row.
    let page = std::fs::read_to_string(d.join("s.html")).unwrap();
    assert!(page.contains("<h1>Blinn against Phong</h1>") && page.contains(">blinn, soft shadows</th>"));
    let cells: Vec<Vec<u8>> = page
        .split("src=\"data:image/png;base64,")
        .skip(1)
        .map(|s| base64::engine::general_purpose::STANDARD.decode(s.split('"').next().unwrap()).unwrap())
        .collect();
    assert_eq!(cells.len(), 4);
    let width = image::load_from_memory(&cells[0]).unwrap().width().to_string();

    // The same images from `lancer render`, at the cells' width.
    let scene = repo("scenes/glass.toml");
    let render = |name: &str, extra: &[&str]| {
        let mut args = vec!["render", scene.as_str(), "--width", &width, "-q", "-o"];
        let out = format!("{name}.png");
        let aov = format!("{name}-aov");
        args.extend([out.as_str(), "--aov", &aov, "--aov-format", "png"]);
        args.extend(extra);
        let o = lancer(d, &args);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    render("phong", &[]);
    render("blinn", &["--terms", "ambient,diffuse,specular:blinn", "--shadows", "soft:samples=4"]);
    let read = |p: &str| std::fs::read(d.join(p)).unwrap();
    let want = [read("phong-aov/specular.png"), read("blinn-aov/specular.png"), read("phong.png"), read("blinn.png")];
    let sheet = image::open(d.join("s.png")).unwrap().into_rgb8();
    assert_eq!(sheet.width(), 640);
    for (k, (cell, want)) in cells.iter().zip(&want).enumerate() {
        assert!(cell == want, "cell {k} is not the PNG lancer render writes, byte for byte");
        let pixels = image::load_from_memory(want).unwrap().into_rgb8();
        assert!(find(&sheet, &pixels).is_some(), "cell {k} is not in the sheet's picture");
    }
    assert!(cells[0] != cells[1], "the columns differ");
}

#[test]
fn a_mistaken_sheet_is_a_located_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bad = SHEET.replace("SCENE", &repo("scenes/glass.toml")).replace("specular:blinn", "specular:blin");
    std::fs::write(d.join("s.toml"), bad).unwrap();
    let o = lancer(d, &["sheet", "s.toml", "-o", "s.png"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.starts_with("error: s.toml:10:26: column `blinn, soft shadows`: "), "{e}");
    assert!(e.contains("blin") && e.contains("terms = \"ambient,diffuse,specular:blin\""), "{e}");
    assert_eq!(files(d), ["s.toml"]);
    // An output the command cannot write is refused before anything renders.
    let o = lancer(d, &["sheet", "s.toml", "-o", "s.jpg"]);
    assert!(stderr(&o).contains("must end in .png") && stderr(&o).contains(".html"), "{}", stderr(&o));
}

#[test]
fn the_repositorys_example_sheet_renders_for_a_projector_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &["sheet", &repo("sheets/shine.toml"), "-o", "shine.png", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(dir.path().join("shine.png")).unwrap();
    assert_eq!(img.width(), 1920);
    assert!(img.height() <= 1080, "{} high: it fits a 1920x1080 projector", img.height());
}
