//! `lancer export pov`: a prepared scene written for POV-Ray 3.7 with the handout's mapping
//! (`ambient = ambi`, `diffuse = diff`, `phong = spec·shine`, `phong_size = 1/(1−shine)`,
//! `reflection = spec`, `transmit = alpha` with ambient and diffuse divided by `1 − alpha`,
//! `ior = n`; `specular:blinn` as POV-Ray's half-vector `specular = spec·shine` with
//! `roughness = 1/e`). Objects keep their canonical shapes and get their placement as a
//! `matrix`; the camera's `right` vector is negated so POV-Ray sees Lancer's right-handed
//! coordinates as they are. Positions are written in world space (the prepared scene's are from
//! the camera). What POV-Ray cannot express is listed at the top of the file.

use std::fmt::Write;

use glam::{Affine3A, DVec3, Vec3};
use lancer_core::{Camera, ImageSettings, Material, Pattern, Texture};
use lancer_shading::{Pipeline, Prepared};
use lancer_shapes::{CsgNode, CsgOp, Shape};

/// An exported scene: the `.pov` text, the textures it refers to (file name, image), and what
/// could not be expressed.
pub struct Export {
    /// The POV-Ray scene.
    pub text: String,
    /// Image maps to write beside it: (file name relative to the `.pov`, texture).
    pub textures: Vec<(String, usize)>,
    /// What POV-Ray renders differently, one line each.
    pub notes: Vec<String>,
}

fn v(p: Vec3) -> String {
    format!("<{}, {}, {}>", p.x, p.y, p.z)
}

/// The world coordinate `origin + at` of a prepared frame's coordinate `at`, with the fewest
/// decimals that the frame rounds to `at` again (`at` in f32 from `origin`, as prepare makes
/// it): POV-Ray is given the scene Lancer renders, in the file's own numbers where they were
/// short.
fn world(origin: f64, at: f32) -> String {
    let exact = origin + at as f64;
    for decimals in 0..24 {
        let x: f64 = format!("{exact:.decimals$}").parse().expect("a number Rust wrote");
        if (x - origin) as f32 == at {
            // (`-0` as `0`.)
            return format!("{}", x + 0.0);
        }
    }
    format!("{exact}")
}

/// The world point of the prepared frame's point `at`.
fn point(origin: DVec3, at: Vec3) -> String {
    format!("<{}, {}, {}>", world(origin.x, at.x), world(origin.y, at.y), world(origin.z, at.z))
}

/// An object's placement in the prepared frame as a POV-Ray `matrix` in world space (its
/// translation `origin` further).
fn placed(m: &Affine3A, origin: DVec3) -> String {
    let (x, y, z, t) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis, m.translation);
    let (tx, ty, tz) = (world(origin.x, t.x), world(origin.y, t.y), world(origin.z, t.z));
    format!(
        "matrix <{}, {}, {}, {}, {}, {}, {}, {}, {}, {tx}, {ty}, {tz}>",
        x.x, x.y, x.z, y.x, y.y, y.z, z.x, z.y, z.z
    )
}

fn matrix(m: &Affine3A) -> String {
    let (x, y, z, t) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis, m.translation);
    format!(
        "matrix <{}, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}>",
        x.x, x.y, x.z, y.x, y.y, y.z, z.x, z.y, z.z, t.x, t.y, t.z
    )
}

/// Which of the handout's terms the model has, as plain seed terms (other variants are noted),
/// the highlight as POV-Ray can write it.
struct Terms<'a> {
    ambient: bool,
    diffuse: bool,
    specular: Option<Highlight<'a>>,
    mirror: bool,
    refraction: bool,
}

/// The specular term's form in POV-Ray's finish.
#[derive(Clone, Copy)]
enum Highlight<'a> {
    /// The handout's Phong: `phong spec·shine phong_size 1/(1 − shine)` (also what the variants
    /// POV-Ray has no form for are written as).
    Phong,
    /// Blinn-Phong, `spec · shine · (N·h)^e`: POV-Ray's own half-vector `specular spec·shine`
    /// with `roughness 1/e` (it raises `N·h` to `1/roughness`), `e` the exponent the term says
    /// it uses for the material ([`lancer_shading::Term::highlight_exponent`]).
    Blinn(&'a dyn lancer_shading::Term),
}

/// POV-Ray's anti-aliasing options for the image's sampling: Lancer's adaptive anti-aliasing
/// is POV-Ray's method 1 with the same threshold and grid, without jitter (Lancer's grid is
/// regular) and comparing sRGB-like values (`Antialias_Gamma=2.2`: POV-Ray's default, 2.5,
/// would pick other pixels than the PNG's differences do); uniform samples become POV-Ray's
/// adaptive method 2 with a zero threshold (every pixel supersampled), one sample `-A`.
pub fn antialias_flags(image: &lancer_core::ImageSettings) -> String {
    match image.adaptive {
        Some(a) => format!("+A{} +AM1 +R{} -J Antialias_Gamma=2.2", a.threshold, a.depth),
        None if image.samples > 1 => "+A0.0 +AM2 +R3".to_owned(),
        None => "-A".to_owned(),
    }
}

/// Writes the scene. `texture_stem` names the image files (`<stem>-<k>.png`).
pub fn export(
    prepared: &Prepared,
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    textures: &[Texture],
    texture_stem: &str,
) -> Export {
    let mut notes = Vec::new();
    let mut terms = Terms { ambient: false, diffuse: false, specular: None, mirror: false, refraction: false };
    for t in &pipeline.terms {
        let seed = matches!(
            (t.name.as_str(), t.variant.as_str()),
            ("ambient", "seed")
                | ("diffuse", "lambert")
                | ("specular", "phong")
                | ("specular", "blinn")
                | ("mirror", "constant")
                | ("refraction", "seed")
                | ("refraction", "traced")
        );
        match t.name.as_str() {
            "ambient" => terms.ambient = true,
            "diffuse" => terms.diffuse = true,
            "specular" if t.variant == "blinn" => terms.specular = Some(Highlight::Blinn(t.term.as_ref())),
            "specular" => terms.specular = Some(Highlight::Phong),
            "mirror" => terms.mirror = true,
            "refraction" => {
                terms.refraction = true;
                if t.variant == "seed" && prepared.materials.iter().any(|m| m.alpha > 0.0) {
                    notes.push(
                        "`refraction:seed` crosses transparent objects unshaded; POV-Ray traces inside them as `refraction:traced` does, so the images differ there"
                            .into(),
                    );
                }
            }
            other => notes.push(format!("term `{other}` has no POV-Ray counterpart: left out")),
        }
        if !seed && ["ambient", "diffuse", "specular", "mirror", "refraction"].contains(&t.name.as_str()) {
            notes.push(format!(
                "`{}:{}` is written as the handout's `{}` (POV-Ray has no form for it)",
                t.name, t.variant, t.name
            ));
        }
        if t.weight != 1.0 {
            notes.push(format!("`{}` has weight {}: POV-Ray's finish has no weight, 1 is used", t.name, t.weight));
        }
    }
    match pipeline.shadows.name.as_str() {
        "transmissive" | "soft" if !terms.refraction && prepared.materials.iter().any(|m| m.alpha > 0.0) => notes.push(
            "without the refraction term transparent objects are written opaque, so POV-Ray darkens their shadows fully where Lancer lets alpha through"
                .into(),
        ),
        "transmissive" => {}
        "none" => {}
        "hard" if prepared.materials.iter().any(|m| m.alpha > 0.0) => notes.push(
            "shadows `hard`: in POV-Ray transparent objects let light through to their shadows (as `transmissive`)"
                .into(),
        ),
        "hard" => {}
        "soft" => notes.push("shadows `soft`: area lights become POV-Ray area lights (jittered 8 x 8), not Lancer's stratified samples".into()),
        other => notes.push(format!("shadow model `{other}` has no POV-Ray counterpart: POV-Ray's own shadows")),
    }

    let each_surface = pipeline
        .shadows
        .params
        .iter()
        .any(|(k, v)| k == "each_surface" && *v == lancer_shading::ParamValue::Bool(true));
    if ["transmissive", "soft"].contains(&pipeline.shadows.name.as_str())
        && terms.refraction
        && !each_surface
        && prepared.materials.iter().any(|m| m.alpha > 0.0)
    {
        notes.push(format!(
            "shadows `{}` count a closed transparent object once; POV-Ray lets alpha through at each surface (as `each_surface = true`) and objects inside glass cast their shadow",
            pipeline.shadows.name
        ));
    }
    let sheet = |o: &lancer_shapes::Object| o.shape.is_flat() || !o.shape.is_closed();
    if pipeline.terms.iter().any(|t| t.name == "refraction" && t.variant == "traced")
        && prepared.geometry.objects.iter().any(|o| sheet(o) && prepared.materials[o.material as usize].alpha > 0.0)
    {
        notes.push(
            "`refraction:traced` crosses a transparent plane, disk or open mesh as a thin sheet; POV-Ray refracts into a plane's half-space"
                .into(),
        );
    }
    let mut out = String::new();
    let aspect = image.width as f32 / image.height as f32;
    let horizontal = 2.0 * (camera.tan_half_fov * aspect).atan().to_degrees();
    let _ = writeln!(out, "#version 3.7;\n");
    let _ = writeln!(
        out,
        "global_settings {{\n  assumed_gamma 1.0\n  max_trace_level {}\n  adc_bailout 0\n  ambient_light rgb 1\n}}\n",
        // POV-Ray counts the camera ray as a level: Lancer's depth D is D + 1 levels there.
        pipeline.max_depth as u32 + 1
    );
    let _ = writeln!(
        out,
        "// Lancer is right-handed: the negative `right` makes POV-Ray see the same picture.\ncamera {{\n  perspective\n  location {}\n  sky {}\n  up y\n  right -x*{aspect}\n  angle {horizontal}\n  look_at {}\n}}\n",
        point(camera.origin, Vec3::ZERO),
        v(camera.up),
        point(camera.origin, camera.forward)
    );
    if image.background != Vec3::ZERO {
        let _ = writeln!(out, "background {{ color rgb {} }}\n", v(image.background));
    }
    for light in &prepared.lights {
        let colour = light.color * light.intensity;
        if light.size > 0.0 && pipeline.shadows.name == "soft" {
            let s = light.size;
            let _ = writeln!(
                out,
                "light_source {{ {}, color rgb {}\n  area_light <{s}, 0, 0>, <0, 0, {s}>, 8, 8 jitter adaptive 0\n}}",
                point(prepared.origin, light.at),
                v(colour)
            );
        } else {
            let _ = writeln!(out, "light_source {{ {}, color rgb {} }}", point(prepared.origin, light.at), v(colour));
        }
    }
    let _ = writeln!(out);

    let mut texture_files: Vec<(String, usize)> = Vec::new();
    for (i, object) in prepared.geometry.objects.iter().enumerate() {
        let material = &prepared.materials[object.material as usize];
        let body = shape_text(&object.shape, &mut notes, i);
        let appearance = appearance(
            material,
            &object.shape,
            &terms,
            pipeline,
            textures,
            texture_stem,
            &mut texture_files,
            &mut notes,
            i,
        );
        // The appearance before the placement: POV-Ray moves what comes before a transform with
        // it, so patterns stay in the object's own space as in Lancer.
        let _ = writeln!(
            out,
            "// object {}\n{body}{appearance}  {}\n}}\n",
            i + 1,
            placed(&object.world_from_object, prepared.origin)
        );
    }

    notes.sort();
    notes.dedup();
    let mut text = String::from(
        "// Exported by `lancer export pov` for POV-Ray 3.7 with the handout's mapping:\n\
         //   ambient = ambi, diffuse = diff, phong = spec*shine, phong_size = 1/(1-shine), reflection = spec,\n\
         //   transmit = alpha with ambient and diffuse divided by (1 - alpha), ior = n;\n\
         //   specular:blinn as specular = spec*shine, roughness = 1/exponent (4/(1-shine) if not given).\n",
    );
    let _ = writeln!(
        text,
        "// Render: povray +I<this file> +W{} +H{} {} +O<image>.png",
        image.width,
        image.height,
        antialias_flags(image)
    );
    if notes.is_empty() {
        text.push_str("// Everything in the scene has a POV-Ray counterpart.\n");
    } else {
        text.push_str("// Not expressible in POV-Ray (rendered differently there):\n");
        for n in &notes {
            let _ = writeln!(text, "//   - {n}");
        }
    }
    text.push('\n');
    text.push_str(&out);
    Export { text, textures: texture_files, notes }
}

/// The object's shape in its own space, as an open POV-Ray block (closed by the caller).
fn shape_text(shape: &Shape, notes: &mut Vec<String>, index: usize) -> String {
    match shape {
        Shape::Csg(csg) => {
            let mut s = csg_node(csg.nodes(), csg.root(), notes);
            // The outer block the caller closes.
            s.insert_str(0, "object {\n");
            s
        }
        other => format!("{} {{\n{}", leaf_name(other), leaf_body(other, notes, index)),
    }
}

fn leaf_name(shape: &Shape) -> &'static str {
    match shape {
        Shape::Sphere => "sphere",
        Shape::Cube => "box",
        Shape::Plane => "plane",
        Shape::Cylinder => "cylinder",
        Shape::Cone => "cone",
        Shape::Torus { .. } => "torus",
        Shape::Disk => "disc",
        Shape::Mesh(_) => "mesh2",
        Shape::Csg(_) => "union",
    }
}

/// A leaf's parameters (canonical: unit sphere, cube [-1, 1]³, plane y = 0, cylinder and cone
/// from y = -1 to 1 of radius 1, torus of major radius 1 in the xz-plane, unit disk facing +y).
fn leaf_body(shape: &Shape, notes: &mut Vec<String>, index: usize) -> String {
    match shape {
        Shape::Sphere => "  0, 1\n".into(),
        Shape::Cube => "  <-1, -1, -1>, <1, 1, 1>\n".into(),
        Shape::Plane => "  y, 0\n".into(),
        Shape::Cylinder => "  <0, -1, 0>, <0, 1, 0>, 1\n".into(),
        Shape::Cone => "  <0, -1, 0>, 1, <0, 1, 0>, 0\n".into(),
        Shape::Torus { minor } => format!("  1, {minor}\n"),
        Shape::Disk => "  <0, 0, 0>, y, 1\n".into(),
        Shape::Mesh(m) => {
            let mut s = String::new();
            let list = |items: Vec<String>| items.join(",\n    ");
            let _ = writeln!(
                s,
                "  vertex_vectors {{ {},\n    {}\n  }}",
                m.positions().len(),
                list(m.positions().iter().map(|p| v(*p)).collect())
            );
            if !m.normals().is_empty() {
                let _ = writeln!(
                    s,
                    "  normal_vectors {{ {},\n    {}\n  }}",
                    m.normals().len(),
                    list(m.normals().iter().map(|n| v(*n)).collect())
                );
            }
            if !m.uvs().is_empty() {
                let _ = writeln!(
                    s,
                    "  uv_vectors {{ {},\n    {}\n  }}",
                    m.uvs().len(),
                    list(m.uvs().iter().map(|t| format!("<{}, {}>", t.x, t.y)).collect())
                );
            }
            let faces: Vec<String> = m.triangles().iter().map(|t| format!("<{}, {}, {}>", t[0], t[1], t[2])).collect();
            let _ = writeln!(s, "  face_indices {{ {},\n    {}\n  }}", faces.len(), list(faces));
            if m.is_closed() {
                s.push_str("  inside_vector y\n");
            } else {
                let _ = index;
                notes.push("open meshes have no inside in POV-Ray either: glass on one refracts at each crossing in Lancer, not in POV-Ray".into());
            }
            s
        }
        Shape::Csg(_) => unreachable!("CSG is written by csg_node"),
    }
}

fn csg_node(nodes: &[CsgNode], at: u32, notes: &mut Vec<String>) -> String {
    match &nodes[at as usize] {
        CsgNode::Leaf { shape, node_from_leaf } => {
            format!("  {} {{\n{}  {}\n  }}\n", leaf_name(shape), leaf_body(shape, notes, 0), matrix(node_from_leaf))
        }
        CsgNode::Op { op, a, b } => {
            let name = match op {
                CsgOp::Union => "union",
                CsgOp::Intersection => "intersection",
                CsgOp::Difference => "difference",
            };
            format!("  {name} {{\n{}{}  }}\n", csg_node(nodes, *a, notes), csg_node(nodes, *b, notes))
        }
    }
}

/// The pigment, finish and interior of `m` on `shape`.
#[allow(clippy::too_many_arguments)]
fn appearance(
    m: &Material,
    shape: &Shape,
    terms: &Terms,
    pipeline: &Pipeline,
    textures: &[Texture],
    texture_stem: &str,
    files: &mut Vec<(String, usize)>,
    notes: &mut Vec<String>,
    _index: usize,
) -> String {
    let alpha = if terms.refraction { m.alpha.clamp(0.0, 1.0) } else { 0.0 };
    let transmit = if alpha > 0.0 {
        format!("rgbt <{}, {}, {}, {alpha}>", m.color.x, m.color.y, m.color.z)
    } else {
        format!("rgb {}", v(m.color))
    };
    let pigment = match m.pattern {
        Pattern::Solid => format!("pigment {{ color {transmit} }}"),
        Pattern::Checker { other, scale } => {
            let second = if alpha > 0.0 {
                format!("rgbt <{}, {}, {}, {alpha}>", other.x, other.y, other.z)
            } else {
                format!("rgb {}", v(other))
            };
            // Lancer's cells are offset by 1e-4 of a cell (faces on a cell boundary stay on one
            // side): the same offset here (checked against POV-Ray 3.7: patterns 47 dB with it,
            // 11 dB with POV-Ray's own tolerance assumed instead).
            let t = -1e-4 * scale;
            format!("pigment {{ checker color {transmit} color {second} scale {scale} translate <{t}, {t}, {t}> }}")
        }
        Pattern::Image { texture, scale } => {
            let known = textures.get(texture as usize).is_some();
            let name = format!("{texture_stem}-{texture}.png");
            if known && !files.iter().any(|(f, _)| *f == name) {
                files.push((name.clone(), texture as usize));
            }
            match shape {
                Shape::Mesh(mesh) if !mesh.uvs().is_empty() => {
                    format!("uv_mapping pigment {{ image_map {{ png \"{name}\" interpolate 2 }} }}")
                }
                // Lancer's u = 0.5 + atan2(z, x)/2π, v = 0.5 + asin(y)/π; POV-Ray's spherical
                // map starts u half a turn round.
                Shape::Sphere => {
                    format!("pigment {{ image_map {{ png \"{name}\" map_type 1 interpolate 2 }} rotate y*180 }}")
                }
                // Lancer maps (x, z) / scale on a plane or disk, the image repeating; POV-Ray's
                // planar map lies in its xy-plane: turned down onto xz.
                Shape::Plane | Shape::Disk => {
                    format!("pigment {{ image_map {{ png \"{name}\" interpolate 2 }} rotate x*90 scale {scale} }}")
                }
                _ => {
                    notes.push(format!(
                        "image textures on a {} map differently in POV-Ray: its base colour is used",
                        shape.name()
                    ));
                    format!("pigment {{ color {transmit} }}")
                }
            }
        }
    };
    let keep = 1.0 - alpha;
    let scale_by = if keep > 0.0 { 1.0 / keep } else { 1.0 };
    let ambient = if terms.ambient { m.ambi * scale_by } else { 0.0 };
    let diffuse = if terms.diffuse { m.diff * scale_by } else { 0.0 };
    let highlight = match terms.specular {
        Some(Highlight::Phong) if m.shine > 0.0 && m.shine < 1.0 => {
            format!("phong {} phong_size {}", m.spec * m.shine, 1.0 / (1.0 - m.shine))
        }
        Some(Highlight::Blinn(term)) => {
            match term.highlight_exponent(m) {
                // In f64: an exponent below f32's smallest normal still has a finite inverse
                // (POV-Ray raises to 1/roughness, so a huge roughness is Lancer's `c^0`).
                Some(e) if m.spec * m.shine > 0.0 => {
                    format!("specular {} roughness {}", m.spec * m.shine, 1.0 / f64::from(e))
                }
                _ => "phong 0 phong_size 1".to_owned(),
            }
        }
        _ => "phong 0 phong_size 1".to_owned(),
    };
    let reflection = if terms.mirror { m.spec } else { 0.0 };
    let mut s = format!(
        "  {pigment}\n  finish {{ ambient {ambient} diffuse {diffuse} {highlight} reflection {reflection} }}\n"
    );
    if alpha > 0.0 {
        let _ = writeln!(s, "  interior {{ ior {} }}", m.n);
    }
    if pipeline.shadows.name == "none" {
        s.push_str("  no_shadow\n");
    }
    s
}
