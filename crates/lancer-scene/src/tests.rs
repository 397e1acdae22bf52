//! Unit tests of scene and model loading: what loads, and how each kind of mistake is reported.

use lancer_core::{Light, Material};
use lancer_shading::Registry;
use lancer_shapes::Shape;

use crate::{LoadErrorKind, load_model, load_scene};

const CAMERA: &str = "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n";

fn err(src: &str) -> crate::LoadError {
    match load_scene(src, "s.toml", &Registry::with_builtins()) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(e) => e,
    }
}

/// The (line, column) of the first occurrence of `needle` in `src`.
fn pos(src: &str, needle: &str) -> (usize, usize) {
    let at = src.find(needle).unwrap();
    (src[..at].matches('\n').count() + 1, at - src[..at].rfind('\n').map_or(0, |i| i + 1) + 1)
}

#[test]
fn a_full_scene_loads_into_the_world() {
    let src = format!(
        "{CAMERA}fov = 30\n[image]\nwidth = 32\nheight = 16\nsamples = 4\nbackground = [0.1, 0.2, 0.3]\n\
         [materials.red]\ncolor = [1, 0, 0]\nspec = 0.5\nshine = 0.9\n\
         [[lights]]\nat = [1, 2, 3]\nintensity = 0.5\n\
         [[objects]]\nshape = \"sphere\"\nmaterial = \"red\"\nscale = [1, 2, 3]\nrotate = [0, 90, 0]\ntranslate = [1, 0, 0]\n\
         [[objects]]\nshape = \"plane\"\nmaterial = {{ color = [0, 1, 0], ambi = 0 }}\n\
         [[objects]]\nshape = \"cube\"\n"
    );
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap();
    let s = &l.scene;
    assert_eq!((s.image.width, s.image.height, s.image.samples), (32, 16, 4));
    assert_eq!(s.world.query::<&Shape>().iter().count(), 3);
    assert_eq!(s.world.query::<&Material>().iter().count(), 2, "one named, one inline");
    let lights: Vec<Light> = s.world.query::<&Light>().iter().copied().collect();
    assert_eq!(
        lights,
        [Light { at: glam::Vec3::new(1.0, 2.0, 3.0), color: glam::Vec3::ONE, intensity: 0.5, size: 0.0 }]
    );
    // No [model]: the handout's five terms in order, hard shadows, depth 5.
    let names: Vec<&str> = l.pipeline.terms.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["ambient", "diffuse", "specular", "mirror", "refraction"]);
    assert_eq!((l.pipeline.shadows.name.as_str(), l.pipeline.max_depth), ("hard", 5));
}

#[test]
fn rotation_is_x_then_y_then_z_and_right_handed() {
    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"cube\"\nscale = [2, 1, 1]\nrotate = [90, 90, 0]\ntranslate = [0, 0, 5]\n"
    );
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap();
    let t = *l.scene.world.query::<&lancer_core::Transform>().iter().next().unwrap();
    let m = t.world_from_object;
    // Object +x (scaled by 2): about x it stays, then about y (+90°) +x goes to -z.
    assert!((m.transform_vector3(glam::Vec3::X) - glam::Vec3::new(0.0, 0.0, -2.0)).length() < 1e-5);
    // Object +y: about x (+90°) goes to +z, then about y to +x.
    assert!((m.transform_vector3(glam::Vec3::Y) - glam::Vec3::X).length() < 1e-5);
    assert!((m.transform_point3(glam::Vec3::ZERO) - glam::Vec3::new(0.0, 0.0, 5.0)).length() < 1e-6);
}

#[test]
fn model_tables_variants_and_parameters() {
    let src = format!(
        "{CAMERA}[model]\nmax_depth = 2\nshadows = {{ model = \"transmissive\", tint = true }}\n\
         terms = [\"ambient\", {{ term = \"specular\", variant = \"phong\" }}]\n"
    );
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap();
    let names: Vec<(&str, &str)> = l.pipeline.terms.iter().map(|t| (t.name.as_str(), t.variant.as_str())).collect();
    assert_eq!(names, [("ambient", "seed"), ("specular", "phong")]);
    assert_eq!((l.pipeline.shadows.name.as_str(), l.pipeline.max_depth), ("transmissive", 2));
    let m = load_model("max_depth = 0\nterms = [\"diffuse\"]\n", "m.toml", &Registry::with_builtins()).unwrap();
    assert_eq!((m.terms.len(), m.max_depth), (1, 0));
}

#[test]
fn unknown_key_names_file_line_column_and_the_keys_expected() {
    let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\ncolour = [1, 0, 0]\n");
    let e = err(&src);
    assert_eq!((e.file.as_str(), e.line, e.column), ("s.toml", 6, 1));
    let msg = e.to_string();
    assert!(msg.starts_with("s.toml:6:1: unknown field `colour`, expected one of `shape`, `material`"), "{msg}");
}

#[test]
fn non_finite_and_out_of_range_numbers_are_refused_where_they_stand() {
    let src = format!("{CAMERA}[[lights]]\nat = [1, inf, 0]\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "inf"));
    assert!(e.to_string().contains("expected a finite number, found inf"), "{e}");

    let src = format!("{CAMERA}[materials.m]\nshine = 1.5\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "1.5"));
    assert!(e.to_string().contains("expected a number in [0, 1], found 1.5"), "{e}");

    let src = format!("{CAMERA}[materials.m]\nn = nan\n");
    assert!(err(&src).to_string().contains("expected a finite number, found NaN"));

    let src = format!("{CAMERA}[image]\nwidth = 0\n");
    assert!(err(&src).to_string().contains("expected a whole number in [1, 16384], found 0"));

    let src = format!("{CAMERA}[[objects]]\nshape = \"cube\"\nscale = [1, 0, 1]\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "[1, 0, 1]"));
    assert!(e.to_string().contains("scale factor of zero"));

    let src = format!("{CAMERA}[[objects]]\nshape = \"cube\"\nscale = 2e6\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "2e6"));
    assert!(e.to_string().contains("at most 1e6"), "{e}");
}

#[test]
fn regression_every_scale_the_loader_accepts_prepares() {
    // The loader and the geometry test placements the same way: the smallest factors the format
    // allows, on an object and composed through CSG operands, load and prepare (before the fix
    // `scale = 0.00005` loaded and then failed to prepare, with no file, line or column).
    for src in [
        format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nscale = 0.00005\n"),
        format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nscale = [1e-6, 1e6, 1e-6]\n"),
        format!(
            "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\nscale = 1e-6\n\
             a = {{ shape = \"sphere\", scale = 1e-6 }}\nb = {{ shape = \"cube\" }}\n"
        ),
    ] {
        let loaded = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
        lancer_shading::prepare(&loaded.scene).unwrap_or_else(|e| panic!("{src}: {e}"));
    }
    // Composed past what single precision can invert (10⁻¹⁸ per axis): a located error at load.
    let inner = "{ shape = \"csg\", op = \"union\", scale = 1e-6, a = { shape = \"sphere\", scale = 1e-6 }, b = { shape = \"cube\" } }";
    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\n\
         a = {{ shape = \"csg\", op = \"union\", scale = 1e-6, a = {inner}, b = {{ shape = \"cube\" }} }}\n\
         b = {{ shape = \"cube\" }}\n"
    );
    let e = err(&src);
    assert!(e.line > 0 && e.to_string().contains("singular"), "{e}");
}

#[test]
fn unknown_names_point_at_the_name_and_suggest_the_nearest() {
    let src = format!("{CAMERA}[materials.glass]\nalpha = 1\n[[objects]]\nshape = \"sphere\"\nmaterial = \"glas\"\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"glas\""));
    assert_eq!(
        *e.kind,
        LoadErrorKind::UnknownMaterial {
            name: "glas".into(),
            nearest: Some("glass".into()),
            known: vec!["glass".into()]
        }
    );

    let src = format!("{CAMERA}[[objects]]\nshape = \"sphre\"\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"sphre\""));
    assert!(
        e.to_string().contains("unknown shape `sphre` (did you mean `sphere`?); known shapes: sphere, cube, plane")
    );

    let src = format!("{CAMERA}[model]\nterms = [\"ambient\", \"difuse\"]\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"difuse\""));
    assert!(
        e.to_string().contains("unknown term `difuse` (did you mean `diffuse`?); known terms: ambient, diffuse"),
        "{e}"
    );

    let src = format!("{CAMERA}[model]\nshadows = \"sofft\"\n");
    assert!(err(&src).to_string().contains("unknown shadow model `sofft`"));

    let src = format!("{CAMERA}[model]\nterms = [{{ term = \"specular\", variant = \"blin\" }}]\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"blin\""));
    assert!(e.to_string().contains("term `specular` has no variant `blin`"), "{e}");
}

#[test]
fn bad_parameters_point_at_the_parameter() {
    let src = format!("{CAMERA}[model]\nshadows = {{ model = \"transmissive\", tnit = true }}\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "tnit"));
    assert!(e.to_string().contains("`transmissive` has no parameter `tnit` (did you mean `tint`?)"), "{e}");

    let src = format!("{CAMERA}[model]\nshadows = {{ model = \"transmissive\", tint = 3 }}\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "3 }"));
    assert!(e.to_string().contains("expected a boolean, found a number"), "{e}");

    let src = format!("{CAMERA}[model]\nterms = [\"ambient\", \"ambient\"]\n");
    assert!(err(&src).to_string().contains("term `ambient` appears twice"));

    let src = format!("{CAMERA}[model]\nterms = [{{ variant = \"phong\" }}]\n");
    assert!(err(&src).to_string().contains("missing the name"));
}

#[test]
fn bad_camera_and_bad_syntax() {
    let e = err("[camera]\nfrom = [0, 0, 0]\nto = [0, 0, 0]\n");
    assert_eq!(e.line, 1);
    assert!(e.to_string().contains("bad camera: `from` and `to` must be different points"));
    let e = err("[camera\nfrom = 1\n");
    assert_eq!(e.line, 1);
    let e = err("[image]\nwidth = 10\n");
    assert!(e.to_string().contains("missing field `camera`"), "{e}");
    let e = match load_model("terms = [\"ambient\"]\ncolor = 1\n", "m.toml", &Registry::with_builtins()) {
        Err(e) => e,
        Ok(_) => panic!("model files have only model keys"),
    };
    assert_eq!((e.file.as_str(), e.line, e.column), ("m.toml", 2, 1));
}

#[test]
fn torus_minor_is_checked_and_only_for_tori() {
    let ok = format!("{CAMERA}[[objects]]\nshape = \"torus\"\nminor = 0.4\n");
    let l = load_scene(&ok, "s.toml", &Registry::with_builtins()).unwrap();
    assert_eq!(*l.scene.world.query::<&Shape>().iter().next().unwrap(), Shape::Torus { minor: 0.4 });
    let src = format!("{CAMERA}[[objects]]\nshape = \"torus\"\nminor = 1.5\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "1.5"));
    assert!(e.to_string().contains("`minor` must be in (0, 1)"), "{e}");
    let src = format!("{CAMERA}[[objects]]\nshape = \"cone\"\nminor = 0.2\n");
    assert!(err(&src).to_string().contains("`minor` is a torus parameter; a cone has none"));
}

#[test]
fn patterns_load_and_their_mistakes_are_located() {
    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"plane\"\nmaterial = {{ color = {{ pattern = \"checker\", colors = [[1, 1, 1], [0, 0, 0]], scale = 2 }} }}\n"
    );
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap();
    let m = *l.scene.world.query::<&Material>().iter().next().unwrap();
    assert_eq!(m.pattern, lancer_core::Pattern::Checker { other: glam::Vec3::ZERO, scale: 2.0 });

    let src = format!("{CAMERA}[materials.m]\ncolor = {{ pattern = \"chekcer\", colors = [[1, 1, 1], [0, 0, 0]] }}\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"chekcer\""));
    assert!(e.to_string().contains("unknown pattern `chekcer` (did you mean `checker`?)"), "{e}");

    let src = format!("{CAMERA}[materials.m]\ncolor = {{ pattern = \"checker\" }}\n");
    assert!(err(&src).to_string().contains("a checker needs `colors"));

    let src = format!("{CAMERA}[materials.m]\ncolor = {{ pattern = \"image\", path = \"nope.png\" }}\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"nope.png\""));
    assert!(e.to_string().contains("texture `nope.png`: cannot read `nope.png`"), "{e}");

    // Through a resolver: a real PNG loads, sRGB-decoded to linear; garbage is a located error.
    let png = {
        let img = image::RgbImage::from_pixel(2, 1, image::Rgb([188, 188, 188]));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    };
    let resolve = |p: &str| if p == "ok.png" { Ok(png.clone()) } else { Ok(b"not an image".to_vec()) };
    let src = format!("{CAMERA}[materials.m]\ncolor = {{ pattern = \"image\", path = \"ok.png\" }}\n");
    let l = crate::load_scene_with(&src, "s.toml", &Registry::with_builtins(), &resolve).unwrap();
    let t = &l.scene.textures[0];
    assert!((t.texel(0).x - 0.5029).abs() < 1e-3, "sRGB 188 is linear 0.503, got {}", t.texel(0).x);
    let src = format!("{CAMERA}[materials.m]\ncolor = {{ pattern = \"image\", path = \"bad.png\" }}\n");
    let e = match crate::load_scene_with(&src, "s.toml", &Registry::with_builtins(), &resolve) {
        Err(e) => e,
        Ok(_) => panic!("garbage is not an image"),
    };
    assert!(e.to_string().contains("texture `bad.png`"), "{e}");
}

#[test]
fn csg_objects_and_their_mistakes() {
    let ok = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"difference\"\na = {{ shape = \"cube\" }}\n\
         b = {{ shape = \"csg\", op = \"union\", a = {{ shape = \"sphere\" }}, b = {{ shape = \"cylinder\", scale = 0.5 }}, translate = [0, 1, 0] }}\n"
    );
    let l = load_scene(&ok, "s.toml", &Registry::with_builtins()).unwrap();
    assert!(matches!(l.scene.world.query::<&Shape>().iter().next().unwrap(), Shape::Csg(_)));

    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"diference\"\na = {{ shape = \"cube\" }}\nb = {{ shape = \"sphere\" }}\n"
    );
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"diference\""));
    assert!(e.to_string().contains("unknown csg operation `diference` (did you mean `difference`?)"), "{e}");

    let src = format!("{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\na = {{ shape = \"cube\" }}\n");
    assert!(err(&src).to_string().contains("a csg shape needs operand `b"));

    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\na = {{ shape = \"disk\" }}\nb = {{ shape = \"cube\" }}\n"
    );
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "\"disk\""));
    assert!(e.to_string().contains("a disk has no inside, so it cannot be a csg operand"), "{e}");

    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\na = {{ shape = \"cube\", material = \"x\" }}\nb = {{ shape = \"cube\" }}\n"
    );
    assert!(err(&src).to_string().contains("unknown field `material`"));

    let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nop = \"union\"\n");
    assert!(err(&src).to_string().contains("`op` belongs to a csg shape; a sphere has none"));
}

#[test]
fn meshes_load_through_the_resolver_and_bad_files_are_located_errors() {
    let files = |name: &str| -> Result<Vec<u8>, String> {
        Ok(match name {
            "tri.obj" => b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
            "range.obj" => b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n".to_vec(),
            "flat.obj" => b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n".to_vec(),
            "one-flat.obj" => b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n".to_vec(),
            "junk.obj" => b"v 0 0 zero\nf 1 2 3\n".to_vec(),
            _ => return Err("No such file or directory (os error 2)".into()),
        })
    };
    let scene = |path: &str| format!("{CAMERA}[[objects]]\nshape = \"mesh\"\npath = \"{path}\"\n");
    let load = |src: &str| crate::load_scene_with(src, "s.toml", &Registry::with_builtins(), &files);
    let l = load(&scene("tri.obj")).unwrap_or_else(|e| panic!("{e}"));
    match l.scene.world.query::<&Shape>().iter().next().unwrap() {
        Shape::Mesh(m) => assert!(m.triangle_count() == 1 && !m.is_closed()),
        other => panic!("{other:?}"),
    }
    for (path, message) in [
        ("missing.obj", "mesh `missing.obj`: No such file or directory"),
        ("range.obj", "mesh `range.obj`: not a readable OBJ file"),
        ("flat.obj", "mesh `flat.obj`: every triangle (1) is degenerate"),
        ("junk.obj", "mesh `junk.obj`: not a readable OBJ file"),
    ] {
        let src = scene(path);
        let e = match load(&src) {
            Err(e) => e,
            Ok(_) => panic!("{path} should not load"),
        };
        assert_eq!((e.line, e.column), pos(&src, &format!("\"{path}\"")), "{path}");
        assert!(e.to_string().contains(message), "{path}: {e}");
    }
    // A real file's degenerate triangle is skipped, with a located warning giving the count.
    let src = scene("one-flat.obj");
    let l = load(&src).unwrap_or_else(|e| panic!("{e}"));
    match l.scene.world.query::<&Shape>().iter().next().unwrap() {
        Shape::Mesh(m) => assert_eq!(m.triangle_count(), 1),
        other => panic!("{other:?}"),
    }
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    let (line, column) = pos(&src, "\"one-flat.obj\"");
    assert!(
        w.contains(&format!(
            "warning: s.toml:{line}:{column}: mesh `one-flat.obj`: 1 degenerate triangle (corners on one line) skipped of 2"
        )),
        "{w:?}"
    );
    let src = format!("{CAMERA}[[objects]]\nshape = \"mesh\"\n");
    assert!(err(&src).to_string().contains("a mesh needs `path"));
    let src = format!(
        "{CAMERA}[[objects]]\nshape = \"csg\"\nop = \"union\"\na = {{ shape = \"mesh\" }}\nb = {{ shape = \"cube\" }}\n"
    );
    assert!(err(&src).to_string().contains("a mesh cannot be a csg operand"));
    let src = format!("{CAMERA}[[objects]]\nshape = \"cube\"\npath = \"x.obj\"\n");
    assert!(err(&src).to_string().contains("`path` belongs to a mesh; a cube has none"));
}

/// Loads a scene whose one object is the mesh `obj` (given as the file `m.obj`).
fn load_mesh(obj: &str) -> Result<crate::Loaded, crate::LoadError> {
    load_mesh_bytes(obj.as_bytes())
}

fn load_mesh_bytes(obj: &[u8]) -> Result<crate::Loaded, crate::LoadError> {
    let src = format!("{CAMERA}[[objects]]\nshape = \"mesh\"\npath = \"m.obj\"\n");
    let resolve = |_: &str| Ok(obj.to_vec());
    crate::load_scene_with(&src, "s.toml", &Registry::with_builtins(), &resolve)
}

#[test]
fn regression_faces_that_mix_corner_kinds_load_flat_with_a_warning() {
    // A file mixing `f 1//1 ...` and `f 4 5 6` has no normal for some corners: filling them
    // from other corners would make normals up, and refusing it refused real files (an
    // exporter's raft with `v/vt` faces after plain ones): it loads with positions only.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 4\n";
    let l = load_mesh(obj).unwrap_or_else(|e| panic!("{e}"));
    match l.scene.world.query::<&Shape>().iter().next().unwrap() {
        Shape::Mesh(m) => {
            assert!(m.triangle_count() == 2 && !m.is_smooth(), "{} {}", m.triangle_count(), m.is_smooth())
        }
        other => panic!("{other:?}"),
    }
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert!(
        w.iter().any(|w| w.contains("line 7 gives its corners normals or texture coordinates differently")
            && w.contains("flat shading")),
        "{w:?}"
    );
}

#[test]
fn real_obj_quirks_load_or_say_what_is_wrong() {
    // A broken `usemtl` (materials come from the scene), no faces, UTF-16 text.
    let l = load_mesh("mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl \nf 1 2 3\n").unwrap_or_else(|e| panic!("{e}"));
    assert!(l.warnings.is_empty() || l.warnings.iter().all(|w| !w.message.contains("mesh")));
    let e = load_mesh("v 0 0 0\nv 1 0 0\n").err().expect("no faces");
    assert!(e.to_string().contains("the file has no faces"), "{e}");
    let utf16: Vec<u8> = [0xFF, 0xFE].into_iter().chain("v 0 0 0\n".bytes().flat_map(|b| [b, 0])).collect();
    let e = load_mesh_bytes(&utf16).err().expect("UTF-16 is refused");
    assert!(e.to_string().contains("UTF-16 text; save it as UTF-8"), "{e}");
}

#[test]
fn normals_indexed_apart_from_positions_load_as_a_smooth_mesh() {
    // A square of two triangles whose corners share positions but take different normals: four
    // positions, two normals, five distinct corners (position, normal).
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//1 4//2\n";
    let loaded = load_mesh(obj).unwrap_or_else(|e| panic!("{e}"));
    let shapes: Vec<Shape> = loaded.scene.world.query::<&Shape>().iter().cloned().collect();
    let Shape::Mesh(m) = &shapes[0] else { panic!("a mesh") };
    assert_eq!(m.triangle_count(), 2);
    assert!(m.is_smooth());
}

#[test]
fn loading_warns_about_unused_materials_bright_colours_and_no_lights() {
    let src = format!(
        "{CAMERA}[materials.spare]\ncolor = [0.5, 0.5, 0.5]\n[materials.used]\ncolor = [1.5, 0.2, 0.2]\n\
         [[objects]]\nshape = \"sphere\"\nmaterial = \"used\"\n"
    );
    let l = crate::load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    let at = |needle: &str| {
        let (line, column) = pos(&src, needle);
        format!("s.toml:{line}:{column}")
    };
    assert!(w.iter().any(|w| w.contains("no [[lights]]")), "{w:?}");
    assert!(
        w.contains(&format!("warning: {}: material `spare` is defined but no object uses it", at("[materials.spare]"))),
        "{w:?}"
    );
    assert!(
        w.iter().any(|x| x.starts_with(&format!("warning: {}: a material colour above 1 (1.5)", at("[1.5")))),
        "{w:?}"
    );
    assert_eq!(w.len(), 3, "{w:?}");
}

#[test]
fn regression_colours_are_bounded_so_products_along_a_ray_stay_finite() {
    // Found by the fuzzer: a colour of 1e30 made absorption and tinted shadows infinite.
    for bad in ["[1e30, 0.5, 0.5]", "[0.5, -0.1, 0.5]", "[0.5, 0.5, 1000.5]"] {
        let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nmaterial = {{ color = {bad} }}\n");
        let e = err(&src);
        assert_eq!((e.line, e.column), pos(&src, bad), "{bad}");
        assert!(e.to_string().contains("channels in [0, 1000]"), "{e}");
    }
    let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nmaterial = {{ color = [1000, 0, 0] }}\n");
    assert!(crate::load_scene(&src, "s.toml", &Registry::with_builtins()).is_ok());
}

#[test]
fn messages_a_student_meets_are_in_the_formats_words() {
    let registry = Registry::with_builtins();
    let load = |src: &str| crate::load_scene(src, "s.toml", &registry);
    let message = |src: &str| match load(src) {
        Err(e) => (e.line, e.column, e.to_string()),
        Ok(_) => panic!("should not load: {src}"),
    };
    // A whole number written with a point is that number; a fraction is refused in plain words.
    let src = format!("{CAMERA}[image]\nwidth = 480.0\nheight = 270\n");
    assert_eq!(load(&src).unwrap().scene.image.width, 480);
    let (.., m) = message(&format!("{CAMERA}[image]\nwidth = 480.5\n"));
    assert!(m.contains("expected a whole number in [1, 16384], found 480.5") && !m.contains("i64"), "{m}");
    // A single term without brackets.
    let (.., m) = message(&format!("{CAMERA}[model]\nterms = \"ambient\"\n"));
    assert!(
        m.contains("expected a list of terms in brackets: terms = [\"ambient\"]") && !m.contains("sequence"),
        "{m}"
    );
    // A negative weight: no forty-digit bound.
    let (.., m) = message(&format!("{CAMERA}[model]\nterms = [{{ term = \"ambient\", weight = -1 }}]\n"));
    assert!(m.contains("expected a number of at least 0, found -1"), "{m}");
    // Misspelled keys get the nearest.
    let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nmaterial = {{ shiny = 0.5 }}\n");
    assert!(message(&src).2.contains("(did you mean `shine`?)"));
    let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\nmaterial = {{ colour = [1, 0, 0] }}\n");
    assert!(message(&src).2.contains("(did you mean `color`?)"));
    // `exponent` on the default specular names the variants that take it.
    let (.., m) = message(&format!("{CAMERA}[model]\nterms = [{{ term = \"specular\", exponent = 64 }}]\n"));
    assert!(m.contains("variants blinn, blinn-normalized of `specular` take `exponent`"), "{m}");
    // A missing `]` is reported at the end of its own line, not at the start of the next.
    let src = "[camera]\nfrom = [0, 0, -5\n\n# the target\nto = [0, 0, 0]\n";
    let (line, column, m) = message(src);
    assert_eq!((line, column), (2, 17), "{m}");
    assert!(m.contains("or the `]` that closes the array"), "{m}");
    // A bad fov is reported at the fov.
    let src = format!("{CAMERA}fov = 180\n");
    let (line, column, m) = message(&src);
    assert_eq!((line, column), pos(&src, "180"), "{m}");
    assert!(m.contains("strictly between 0 and 180"), "{m}");
}

#[test]
fn regression_pattern_scales_and_light_intensities_are_bounded() {
    // Found by the fuzzer: a checker or image `scale` of 7e-39 made texture coordinates
    // infinite, and an `intensity` of 1e38 made the light infinite.
    for (bad, says) in [
        ("material = { color = { pattern = \"checker\", scale = 7e-39 } }", "between 1e-6 and 1e6"),
        ("material = { color = { pattern = \"checker\", scale = 1e7 } }", "between 1e-6 and 1e6"),
    ] {
        let src = format!("{CAMERA}[[objects]]\nshape = \"sphere\"\n{bad}\n");
        assert!(err(&src).to_string().contains(says), "{bad}: {}", err(&src));
    }
    for bad in ["intensity = 1e38", "size = 1e7", "intensity = -1"] {
        let src = format!("{CAMERA}[[lights]]\nat = [0, 1, 0]\n{bad}\n");
        let e = err(&src);
        assert_eq!(e.line, 6, "{bad}: {e}");
        assert!(e.to_string().contains("1000000"), "{bad}: {e}");
    }
}

/// A scene of `n` spheres in `[[objects]]` tables, some indented, some after a comment with
/// multi-byte characters, a CSG object with its operands in `[objects.a]` / `[objects.b]`
/// subtables every 97th, `[[lights]]` halfway; with the (line, column) each object's table is at.
fn many_objects(n: usize) -> (String, Vec<(usize, usize)>) {
    use std::fmt::Write as _;
    let mut src = format!("{CAMERA}[materials.m]\ncolor = [0.5, 0.5, 0.5]\n[materials.spare]\n");
    let mut places = Vec::with_capacity(n);
    // Lines counted as the text grows (counting from the start for each object is the quadratic
    // cost this guards against).
    let (mut lines, mut counted) = (1, 0);
    for k in 0..n {
        if k == n / 2 {
            src.push_str("[[lights]]\nat = [0, 5, 0]\n");
        }
        if k % 7 == 3 {
            src.push_str("# sphère n° ✓\n");
        }
        let indent = if k % 5 == 1 { "  " } else { "" };
        lines += src[counted..].matches('\n').count();
        counted = src.len();
        places.push((lines, indent.len() + 1));
        if k % 97 == 0 {
            let _ = write!(
                src,
                "{indent}[[objects]]\nshape = \"csg\"\nop = \"union\"\ntranslate = [{k}, 0, 0]\n\
                 [objects.a]\nshape = \"sphere\"\n[objects.b]\nshape = \"cube\"\n"
            );
        } else {
            let material = if k == n - 3 { "{ color = [2, 0, 0] }".to_owned() } else { "\"m\"".to_owned() };
            let _ = write!(
                src,
                "{indent}[[objects]]\nshape = \"sphere\"\nmaterial = {material}\nscale = 0.25\ntranslate = [{}, 0.1, {}]\n",
                k % 100,
                k / 100
            );
        }
    }
    (src, places)
}

#[test]
fn regression_quadratic_loading_20000_objects_are_placed_where_they_are_written() {
    // Each object's place was found by counting lines from the start of the file: 10,000
    // objects took 5 s to check. Read in batches now, each place is still its table's.
    let n = 20_000;
    let (src, expected) = many_objects(n);
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    let got: Vec<(usize, usize)> = l.places.objects.iter().map(|p| (p.line, p.column)).collect();
    assert_eq!(got.len(), n);
    let wrong = got.iter().zip(&expected).position(|(g, e)| g != e);
    assert_eq!(wrong, None, "first wrong place: {:?}", wrong.map(|k| (k, got[k], expected[k])));
    assert_eq!(l.scene.world.query::<&Shape>().iter().count(), n);
    // Warnings found in the last batch and in the rest of the file, at their places.
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    let bright = src.rfind("[2, 0, 0]").unwrap();
    let (line, column) = (src[..bright].matches('\n').count() + 1, bright - src[..bright].rfind('\n').unwrap());
    assert!(w.contains(&format!("warning: s.toml:{line}:{column}: a material colour above 1 (2): a surface reflects more light than it receives; the handout's colours are in [0, 1]")), "{w:?}");
    let (line, column) = pos(&src, "[materials.spare]");
    assert!(w.contains(&format!("warning: s.toml:{line}:{column}: material `spare` is defined but no object uses it")));
    // The same file read whole (a quoted header: batches are not used) places everything alike.
    let whole = format!("{src}[\"meta\"]\ntitle = \"t\"\n");
    assert_eq!(crate::scan::scan(&whole, true).unwrap().object_batches, []);
    let w2 = load_scene(&whole, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((w2.places, w2.warnings), (l.places, l.warnings));
    // An error in a late batch is placed in the file, with the source line.
    let typo = src.replace("translate = [73, 0.1, 195]", "translate = [73, 0.1, 195]\nshiny = 1");
    let e = err(&typo);
    let (line, column) = pos(&typo, "shiny");
    assert_eq!((e.line, e.column, e.source_line.as_str()), (line, column, "shiny = 1"), "{e}");
    assert!(e.to_string().contains("unknown field `shiny`"), "{e}");
}

#[test]
fn regression_unused_material_warnings_point_at_their_own_table() {
    // The name was searched for in the text: `red =` was found inside `deep_red =`, and a quoted
    // name not at all (the warning pointed at the start of the file).
    let src = format!(
        "{CAMERA}[materials]\ndeep_red = {{ color = [0.5, 0, 0] }}\nred = {{ color = [1, 0, 0] }}\n\
         [materials.\"my mat\"]\ncolor = [0.2, 0.2, 0.2]\n[[objects]]\nshape = \"sphere\"\nmaterial = \"deep_red\"\n"
    );
    let l = load_scene(&src, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    let w: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    // `red` starts the line after `deep_red`'s.
    let red = (pos(&src, "deep_red = {").0 + 1, 1);
    for (name, (line, column)) in [("red", red), ("my mat", pos(&src, "[materials.\"my mat\"]"))] {
        let warning = format!("warning: s.toml:{line}:{column}: material `{name}` is defined but no object uses it");
        assert!(w.contains(&warning), "{w:?}");
    }
}

#[test]
fn regression_a_polygon_past_the_triangle_budget_is_a_located_error() {
    let polygon = |corners: usize| {
        let mut s = String::from("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n# a long fan\nf");
        for k in 0..corners {
            s.push_str([" 1", " 2", " 3", " 4"][k % 4]);
        }
        s + "\n"
    };
    let files = |name: &str| -> Result<Vec<u8>, String> {
        Ok(match name {
            "big.obj" => polygon(1003).into_bytes(),
            "600.obj" => polygon(602).into_bytes(),
            "500.obj" => polygon(502).into_bytes(),
            _ => return Err("no such file".into()),
        })
    };
    let limits = crate::Limits { max_triangles: 1000, ..Default::default() };
    let load = |paths: &[&str]| {
        let mut src = CAMERA.to_owned();
        for p in paths {
            src += &format!("[[objects]]\nshape = \"mesh\"\npath = \"{p}\"\n");
        }
        let l = crate::load_scene_within(&src, "s.toml", &Registry::with_builtins(), &files, &limits);
        (src, l)
    };
    // 1001 triangles: the corner that makes the 1001st (the 1003rd, from 0 the 1002nd) is at
    // column 3 + 2 * 1002.
    let (src, l) = load(&["big.obj"]);
    let e = l.err().expect("over the budget");
    assert_eq!((e.line, e.column), pos(&src, "\"big.obj\""));
    assert_eq!(
        e.to_string().lines().next().unwrap(),
        format!(
            "s.toml:{}:{}: mesh `big.obj`: big.obj:6:{}: too many triangles: the face's corner here makes triangle 1001 of \
             the scene's meshes: expected at most 1000 triangles; raise it with --max-triangles",
            e.line,
            e.column,
            3 + 2 * 1002
        )
    );
    // The budget is the scene's: meshes add up, a file shared by objects counts once.
    assert!(load(&["600.obj", "600.obj"]).1.is_ok());
    let (_, l) = load(&["600.obj", "500.obj"]);
    let e = l.err().expect("over the budget together").to_string();
    assert!(e.contains("mesh `500.obj`: 500.obj:6:807: too many triangles: the face's corner here makes triangle 1001 of the scene's meshes (the meshes before this one have 600)"), "{e}");
    // Exactly at the budget loads.
    let at_budget = |_: &str| -> Result<Vec<u8>, String> { Ok(polygon(1002).into_bytes()) };
    let src = format!("{CAMERA}[[objects]]\nshape = \"mesh\"\npath = \"m.obj\"\n");
    assert!(crate::load_scene_within(&src, "s.toml", &Registry::with_builtins(), &at_budget, &limits).is_ok());
}

#[test]
fn regression_a_polygon_of_ten_million_corners_is_refused_by_default() {
    // A 20 MB file: one face of 10⁷ + 3 corners fanned into 10⁷ + 1 triangles at 700 MB. It is
    // refused from the counting pass, before any triangle is stored.
    let corners = crate::MAX_TRIANGLES + 3;
    let mut obj = Vec::with_capacity(2 * corners + 32);
    obj.extend_from_slice(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
    for k in 0..corners {
        obj.extend_from_slice([b" 1", b" 2", b" 3"][k % 3]);
    }
    obj.push(b'\n');
    let e = load_mesh_bytes(&obj).err().expect("over the default budget").to_string();
    assert!(e.contains("m.obj:4:20000007: too many triangles"), "{}", &e[..e.len().min(300)]);
    assert!(e.contains("expected at most 10000000 triangles; raise it with --max-triangles"));
}

#[test]
fn regression_only_the_first_error_of_a_file_was_told_now_each_is_in_file_order() {
    // Found in use: a file with three mistakes took three runs to fix, one error at a time.
    let src = format!(
        "{CAMERA}[model]\nterms = [\"ambient\", {{ term = \"diffuse\", roughnes = 3 }}, \"specularr\"]\n\
         [materials.red]\ncolor = {{ pattern = \"chequer\" }}\n\
         [[objects]]\nshape = \"sphere\"\nmaterial = \"blue\"\n\
         [[objects]]\nshape = \"spere\"\nmaterial = \"red\"\n"
    );
    let e = err(&src);
    let all: Vec<(usize, usize)> = e.all().map(|e| (e.line, e.column)).collect();
    let want = [
        pos(&src, "roughnes"),
        pos(&src, "\"specularr"),
        pos(&src, "\"chequer"),
        pos(&src, "\"blue"),
        pos(&src, "\"spere"),
    ];
    assert_eq!(all, want, "{e}");
    let text = e.to_string();
    for says in [
        "has no parameter `roughnes`",
        "unknown term `specularr`",
        "unknown pattern `chequer`",
        "unknown material `blue`",
        "unknown shape `spere`",
    ] {
        assert!(text.contains(says), "{text}");
    }
    // Each is told as alone (place, message, the line underlined), in file order; a material in
    // error is not also "unknown" to the object that names it.
    assert_eq!(text.matches("s.toml:").count(), 5, "{text}");
    assert!(text.find("`roughnes`") < text.find("`spere`"), "{text}");
    assert!(!text.contains("unknown material `red`"), "{text}");
    // Past ten, the rest are counted.
    let many: String = (0..14).map(|k| format!("[[objects]]\nshape = \"sphere\"\nmaterial = \"m{k}\"\n")).collect();
    let e = err(&format!("{CAMERA}{many}"));
    assert_eq!(e.more.len() + 1, crate::error::MAX_ERRORS);
    assert_eq!(e.unshown, 4);
    let text = e.to_string();
    assert!(text.contains("`m0`") && text.contains("`m9`") && !text.contains("`m10`"), "{text}");
    assert!(text.ends_with("and 4 more errors (the first 10 are shown)"), "{text}");
    // A TOML syntax error stops the toml crate at once: it is told alone.
    let e = err(&format!("{CAMERA}[materials.a]\ndiff = 0.5 0.5\n[[objects]]\nshape = \"spere\"\n"));
    assert!(e.more.is_empty(), "{e}");
}

#[test]
fn regression_lights_as_one_table_said_invalid_type_map_expected_a_sequence() {
    let src = format!("{CAMERA}[lights]\nat = [0, 1, 0]\n");
    let e = err(&src);
    assert_eq!((e.line, e.column), pos(&src, "[lights]"));
    assert_eq!(e.kind.to_string(), "`[lights]` is one table; each light is an array entry `[[lights]]`");
    let e = err(&format!("{CAMERA}[objects]\nshape = \"sphere\"\n"));
    assert_eq!(e.kind.to_string(), "`[objects]` is one table; each object is an array entry `[[objects]]`");
}

#[test]
fn regression_a_number_without_a_digit_before_its_point_said_invalid_mantissa() {
    for (written, says) in [
        ("diff = .8", "a number needs a digit before the point: 0.8"),
        ("diff = -.8", "a number needs a digit before the point: -0.8"),
        ("diff = 8.", "a number needs a digit after the point: 8.0"),
    ] {
        let e = err(&format!("{CAMERA}[materials.a]\n{written}\n"));
        assert_eq!(e.kind.to_string(), says, "{written}");
    }
    let e = err(&format!("{CAMERA}[[lights]]\nat = [.5, 1, 0]\n"));
    assert_eq!(e.kind.to_string(), "a number needs a digit before the point: 0.5");
}

/// The warnings of `lancer check` for scene text `src`: loading's and the prepared scene's.
fn warnings(src: &str) -> Vec<String> {
    let l = load_scene(src, "s.toml", &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    let prepared = lancer_shading::prepare(&l.scene).unwrap();
    let mut all: Vec<String> = l.warnings.iter().map(|w| w.message.clone()).collect();
    all.extend(crate::check(&l.scene, &l.pipeline, &prepared, &l.places).into_iter().map(|w| w.message));
    all
}

#[test]
fn regression_shine_1_was_warned_about_as_parameters_that_are_zero() {
    // Found in use: at `shine = 1` the warning said the parameters the highlight reads are zero;
    // they were not: the exponent 1/(1 − shine) is infinite.
    let scene = |model: &str, shine: &str| {
        format!(
            "{CAMERA}[model]\nterms = [\"ambient\", {model}]\n[[lights]]\nat = [0, 5, -5]\n\
             [[objects]]\nshape = \"sphere\"\nmaterial = {{ spec = 0.5, shine = {shine} }}\n"
        )
    };
    let said = warnings(&scene("\"specular\"", "1"));
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(
        said[0].starts_with("term `specular` adds nothing to this scene: on every material, `shine = 1` makes"),
        "{said:?}"
    );
    assert!(said[0].contains("exponent 1/(1 − shine) infinite") && !said[0].contains("zero"), "{said:?}");
    let blinn = warnings(&scene("\"specular:blinn\"", "1"));
    assert!(blinn[0].contains("exponent 4/(1 − shine) infinite"), "{blinn:?}");
    // A fixed exponent does not come from shine: the highlight shows, no warning.
    assert!(warnings(&scene("{ term = \"specular\", variant = \"blinn\", exponent = 64 }", "1")).is_empty());
    // Zero fields are said so, naming them.
    let zero = warnings(&scene("\"specular\"", "0"));
    let end = "on every material, `shine` is 0 (`lancer terms` lists what each term reads)";
    assert!(zero[0].ends_with(end), "{zero:?}");
    let refraction = warnings(&scene("\"refraction\"", "0.5"));
    assert!(refraction[0].contains(": on every material, `alpha` is 0 ("), "{refraction:?}");
    // Materials idle for different reasons: each said once.
    let two = format!("{}[[objects]]\nshape = \"cube\"\nmaterial = {{ spec = 0 }}\n", scene("\"specular\"", "1"));
    let two = warnings(&two);
    assert!(two[0].contains("gives a small sharp one), or `spec` is 0 and `shine` is 0 ("), "{two:?}");
}

#[test]
fn regression_a_light_inside_glass_with_hard_shadows_was_said_to_reach_outside() {
    // With `hard` shadows a shadow ray stops at any surface: the light inside a glass ball
    // lights nothing outside it, which the warning did not say.
    let scene = |shadows: &str, alpha: &str| {
        format!(
            "{CAMERA}[model]\nshadows = \"{shadows}\"\n[[lights]]\nat = [0, 0, 0]\n\
             [[objects]]\nshape = \"sphere\"\nmaterial = {{ alpha = {alpha}, n = 1.5 }}\n\
             [[objects]]\nshape = \"plane\"\ntranslate = [0, -2, 0]\n"
        )
    };
    let inside = |said: Vec<String>| said.into_iter().find(|w| w.starts_with("light 1 is inside object 1")).unwrap();
    let hard = inside(warnings(&scene("hard", "0.9")));
    assert!(hard.contains("with `hard` shadows it lights nothing outside it either"), "{hard}");
    let through = inside(warnings(&scene("transmissive", "0.9")));
    assert!(through.ends_with("its light reaches outside only through transparent shadows"), "{through}");
    assert!(inside(warnings(&scene("hard", "0"))).ends_with("it lights nothing outside that object"));
    let none = inside(warnings(&scene("none", "0")));
    assert!(none.contains("with `none` shadows nothing blocks its light"), "{none}");
}

#[test]
fn samples_take_a_count_or_adaptive_anti_aliasing_and_bad_ones_are_located() {
    let image = |samples: &str| format!("{CAMERA}[image]\nwidth = 8\nsamples = {samples}\n");
    let loaded = |samples: &str| load_scene(&image(samples), "s.toml", &Registry::with_builtins()).unwrap().scene.image;
    let four = loaded("4");
    assert_eq!((four.samples, four.adaptive), (4, None));
    let aa = loaded("{ adaptive = 0.3, depth = 4 }");
    assert_eq!((aa.samples, aa.adaptive), (1, Some(lancer_core::Adaptive { threshold: 0.3, depth: 4 })));
    // The depth is 3 unless given, as POV-Ray's +R.
    assert_eq!(loaded("{ adaptive = 0 }").adaptive.map(|a| a.depth), Some(3));
    for (samples, at, says) in [
        ("{ adaptive = 3.5 }", "3.5", "expected a number in [0, 3], found 3.5"),
        ("{ adaptive = 0.3, depth = 10 }", "10", "expected a whole number in [2, 9], found 10"),
        ("{ adaptive = 0.3, depth = 1 }", "1 }", "expected a whole number in [2, 9], found 1"),
        ("{ adaptive = nan }", "nan", "expected a finite number, found NaN"),
        ("{ adaptive = 0.3, deep = 2 }", "deep", "unknown field `deep`, expected `adaptive` or `depth`"),
        ("{ depth = 2 }", "{ depth", "missing field `adaptive`"),
        ("0", "0\n", "expected a whole number in [1, 4096], found 0"),
        ("\"many\"", "\"many\"", "a whole number of samples per pixel or a table { adaptive = THRESHOLD, depth = N }"),
    ] {
        let src = image(samples);
        let e = err(&src);
        assert_eq!((e.line, e.column), pos(&src, at), "{samples}: {e}");
        assert!(e.to_string().contains(says), "{samples}: {e}");
    }
}
