//! The scenes of the robustness tests (tests/robustness.rs), shared with the reference-path
//! test (tests/reference.rs): the same scene scaled and moved, seen from far away, and one scene
//! per defect found at extreme scales.

use glam::DVec3;
use lancer_scene::Loaded;
use lancer_shading::Registry;

/// Loads scene text whose meshes are generated OBJ text (`files` maps a path to its content).
pub fn load_with(src: &str, files: &[(&str, String)]) -> Loaded {
    let resolve = |rel: &str| {
        files.iter().find(|(p, _)| *p == rel).map(|(_, text)| text.clone().into_bytes()).ok_or(format!("no {rel}"))
    };
    lancer_scene::load_scene_with(src, "test.toml", &Registry::with_builtins(), &resolve)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A UV sphere of radius 1 as OBJ text (one vertex at each pole), with per-vertex normals when
/// `smooth`.
pub fn uv_sphere_obj(smooth: bool, rings: usize, segments: usize) -> String {
    use std::f64::consts::PI;
    use std::fmt::Write;
    let mut s = String::new();
    let mut vertex = |p: DVec3| {
        writeln!(s, "v {} {} {}", p.x, p.y, p.z).unwrap();
        if smooth {
            writeln!(s, "vn {} {} {}", p.x, p.y, p.z).unwrap();
        }
    };
    vertex(DVec3::Y);
    vertex(-DVec3::Y);
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            vertex(DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    // OBJ indices from 1: the poles are 1 and 2, ring i (1..rings) vertex j follows.
    let v = |i: usize, j: usize| match i {
        0 => 1,
        i if i == rings => 2,
        i => 3 + (i - 1) * segments + j % segments,
    };
    let mut tri = |x: usize, y: usize, z: usize| {
        if smooth {
            writeln!(s, "f {x}//{x} {y}//{y} {z}//{z}").unwrap();
        } else {
            writeln!(s, "f {x} {y} {z}").unwrap();
        }
    };
    for i in 0..rings {
        for j in 0..segments {
            // Counter-clockwise seen from outside (y up, phi growing towards +z).
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            if i != 0 {
                tri(a, d, c);
            }
            if i != rings - 1 {
                tri(a, c, b);
            }
        }
    }
    s
}

/// A convex octahedron (flat faces) as OBJ text.
pub fn octahedron_obj() -> String {
    "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
     f 1 3 5\nf 5 3 2\nf 2 3 6\nf 6 3 1\nf 5 4 1\nf 2 4 5\nf 6 4 2\nf 1 4 6\n"
        .to_owned()
}

/// A test scene with every kind of surface (plane, spheres opaque and glass, cube, cylinder, cone,
/// torus, a flat mesh, a CSG difference), placed by `world = s · p + offset`.
pub fn placed_scene(s: f64, offset: DVec3, width: u32) -> String {
    let at = |p: [f64; 3]| {
        let q = DVec3::from(p) * s + offset;
        format!("[{:?}, {:?}, {:?}]", q.x, q.y, q.z)
    };
    let k = |x: f64| format!("{:?}", x * s);
    format!(
        r#"
[image]
width = {width}
height = {h}
background = [0.2, 0.25, 0.3]
[camera]
from = {from}
to = {to}
fov = 40
[model]
max_depth = 4
shadows = "transmissive"
terms = ["ambient", "diffuse", "specular", "mirror", "refraction"]
[materials.glass]
color = [0.95, 0.97, 1.0]
diff = 0.05
spec = 0.1
shine = 0.99
alpha = 0.85
n = 1.5
[materials.matte]
color = [0.8, 0.5, 0.3]
ambi = 0.1
diff = 0.8
spec = 0.3
shine = 0.9
[[lights]]
at = {light}
[[objects]]
shape = "plane"
translate = {floor}
material = {{ color = [0.8, 0.8, 0.8], ambi = 0.1, diff = 0.7, spec = 0.2 }}
[[objects]]
shape = "sphere"
material = "glass"
scale = {r10}
translate = {glass}
[[objects]]
shape = "sphere"
material = "matte"
scale = {r07}
translate = {ball}
[[objects]]
shape = "cube"
material = "matte"
scale = {r05}
rotate = [0, 30, 0]
translate = {cube}
[[objects]]
shape = "cylinder"
material = "matte"
scale = {r04}
translate = {cyl}
[[objects]]
shape = "cone"
material = "glass"
scale = {r05}
translate = {cone}
[[objects]]
shape = "torus"
minor = 0.3
material = "matte"
scale = {r07}
rotate = [60, 20, 0]
translate = {torus}
[[objects]]
shape = "mesh"
path = "octahedron.obj"
material = "matte"
scale = {r06}
translate = {mesh}
[[objects]]
shape = "csg"
op = "difference"
a = {{ shape = "cube" }}
b = {{ shape = "sphere", scale = 1.3 }}
material = "matte"
scale = {r05}
rotate = [0, 40, 0]
translate = {csg}
"#,
        h = width * 9 / 16,
        from = at([0.0, 2.5, -8.0]),
        to = at([0.0, 0.8, 0.0]),
        light = at([-3.0, 8.0, -5.0]),
        floor = at([0.0, 0.0, 0.0]),
        glass = at([-1.2, 1.0, -1.5]),
        ball = at([-2.6, 0.7, 1.0]),
        cube = at([1.4, 0.5, -1.0]),
        cyl = at([2.8, 0.4, 1.0]),
        cone = at([0.3, 0.5, 1.5]),
        torus = at([-0.2, 1.2, 2.5]),
        mesh = at([2.9, 1.6, 3.0]),
        csg = at([-2.4, 0.5, -0.2]),
        r10 = k(1.0),
        r07 = k(0.7),
        r05 = k(0.5),
        r04 = k(0.4),
        r06 = k(0.6),
    )
}

/// A torus, a sphere and a flat convex mesh side by side under a light far overhead, seen from
/// `distance`: nothing can shadow a point that faces the light.
pub fn overhead_scene(distance: f64, shadows: &str) -> String {
    let dir = DVec3::new(0.0, 0.6, -0.8);
    let from = dir * distance;
    let fov = 2.0 * (4.5 / distance).atan().to_degrees();
    format!(
        r#"
[image]
width = 160
height = 90
[camera]
from = [{:?}, {:?}, {:?}]
to = [0, 0, 0]
fov = {fov:?}
[model]
shadows = "{shadows}"
terms = ["ambient", "diffuse"]
[[lights]]
at = [0, 1000, 0]
[[objects]]
shape = "torus"
minor = 0.4
scale = 1.2
material = {{ color = [0.9, 0.6, 0.3], ambi = 0.1, diff = 0.9 }}
[[objects]]
shape = "sphere"
translate = [-3.5, 0, 0]
material = {{ color = [0.3, 0.6, 0.9], ambi = 0.1, diff = 0.9 }}
[[objects]]
shape = "mesh"
path = "octahedron.obj"
translate = [3.5, 0, 0]
material = {{ color = [0.6, 0.9, 0.3], ambi = 0.1, diff = 0.9 }}
"#,
        from.x, from.y, from.z
    )
}

/// A closed room of six slabs whose faces exactly touch (floor, ceiling, four walls), the
/// light outside above the ceiling, the camera inside; everything scaled by `s`. Also a
/// matte ball and a cube resting on the floor inside.
pub fn closed_room(s: f64) -> String {
    let v = |x: f64, y: f64, z: f64| format!("[{}, {}, {}]", x * s, y * s, z * s);
    let slab = |scale: (f64, f64, f64), at: (f64, f64, f64)| {
        format!(
            "[[objects]]\nshape = \"cube\"\nscale = {}\ntranslate = {}\nmaterial = \"wall\"\n",
            v(scale.0, scale.1, scale.2),
            v(at.0, at.1, at.2)
        )
    };
    let mut src = format!(
        "[image]\nwidth = 64\nheight = 36\n[camera]\nfrom = {}\nto = {}\nfov = 70\n\
         [model]\nshadows = \"hard\"\nterms = [\"diffuse\", \"specular\"]\n\
         [materials.wall]\ncolor = [0.8, 0.8, 0.8]\ndiff = 0.9\nspec = 0.3\nshine = 0.8\n\
         [[lights]]\nat = {}\n",
        v(0.0, 2.0, -3.5),
        v(0.0, 0.5, 2.0),
        v(0.3, 9.0, 0.2)
    );
    // Floor y in [-1, 0], ceiling [4, 5]; walls between them, touching both and each other.
    src += &slab((5.0, 0.5, 5.0), (0.0, -0.5, 0.0));
    src += &slab((5.0, 0.5, 5.0), (0.0, 4.5, 0.0));
    src += &slab((0.5, 2.0, 4.0), (-4.5, 2.0, 0.0));
    src += &slab((0.5, 2.0, 4.0), (4.5, 2.0, 0.0));
    src += &slab((5.0, 2.0, 0.5), (0.0, 2.0, -4.5));
    src += &slab((5.0, 2.0, 0.5), (0.0, 2.0, 4.5));
    src += &format!("[[objects]]\nshape = \"sphere\"\ntranslate = {}\nmaterial = \"wall\"\n", v(1.0, 1.0, 1.0));
    src += &format!(
        "[[objects]]\nshape = \"cube\"\nscale = {}\ntranslate = {}\nmaterial = \"wall\"\n",
        v(0.5, 0.5, 0.5),
        v(-1.5, 0.5, 1.0)
    );
    src
}

/// A red ball outside a big mirror sphere, the camera and the light inside.
pub const INSIDE_A_MIRROR_SPHERE: &str = r#"
[image]
width = 64
height = 36
[camera]
from = [0, 0, -3]
to = [0, 0, 0]
fov = 60
[model]
max_depth = 3
shadows = "hard"
terms = ["ambient", "diffuse", "mirror"]
[[lights]]
at = [0, 2, -2]
[[objects]]
shape = "sphere"
scale = 5
material = { color = [0.5, 0.5, 0.5], ambi = 0.1, diff = 0.3, spec = 0.6 }
[[objects]]
shape = "sphere"
translate = [0, 0, -9]
material = { color = [1, 0, 0], ambi = 1, diff = 1 }
"#;

/// The camera inside a closed opaque sphere, the light outside.
pub const INSIDE_AN_OPAQUE_SPHERE: &str = r#"
[image]
width = 64
height = 36
[camera]
from = [0, 0, -1]
to = [0, 0, 1]
fov = 90
[model]
shadows = "hard"
terms = ["ambient", "diffuse"]
[[lights]]
at = [0, 0, -10]
[[objects]]
shape = "sphere"
scale = 3
material = { color = [0.8, 0.8, 0.8], ambi = 0.1, diff = 0.8 }
"#;

/// A glass mesh `ball.obj` of index 1 and `alpha = 1` before a background ([`uv_sphere_obj`]).
pub const GLASS_MESH_OF_INDEX_ONE: &str = r#"
[image]
width = 96
height = 96
background = [0.4, 0.5, 0.6]
[camera]
from = [0, 0, -4]
to = [0, 0, 0]
fov = 40
[model]
max_depth = 5
terms = ["ambient", "refraction"]
[[objects]]
shape = "mesh"
path = "ball.obj"
material = { color = [1, 1, 1], ambi = 0, diff = 0, alpha = 1, n = 1 }
"#;

/// A sphere of the smallest scale the loader accepts, seen from close by.
pub const SMALLEST_SCALE: &str = r#"
[image]
width = 32
height = 32
[camera]
from = [0, 0, -0.0004]
to = [0, 0, 0]
fov = 40
[model]
terms = ["ambient"]
[[objects]]
shape = "sphere"
scale = 0.00005
material = { ambi = 1 }
"#;

/// A cone scaled by `s`, seen from `(0, 1.5 s, −5 s)`, ambient only.
pub fn cone_scene(s: f64) -> String {
    format!(
        r#"
[image]
width = 80
height = 60
[camera]
from = [0, {y:?}, {z:?}]
to = [0, 0, 0]
fov = 40
[model]
terms = ["ambient"]
[[objects]]
shape = "cone"
scale = {s:?}
material = {{ ambi = 1 }}
"#,
        y = 1.5 * s,
        z = -5.0 * s
    )
}

/// Every robustness scene, named: the placed scene as it is, scaled and moved (`width` wide),
/// seen from overhead near and far, the camera inside spheres, the glass meshes, the cones, the
/// smallest scale and the closed rooms.
pub fn all(width: u32) -> Vec<(String, Loaded)> {
    let octahedron = [("octahedron.obj", octahedron_obj())];
    let mut out = Vec::new();
    let placed = [
        ("placed", 1.0, DVec3::ZERO),
        ("placed, scaled by 1e-3", 1e-3, DVec3::ZERO),
        ("placed, scaled by 1e3", 1e3, DVec3::ZERO),
        ("placed, scaled by 1e4", 1e4, DVec3::ZERO),
        ("placed, moved by 1e4", 1.0, DVec3::new(1e4, -2e3, 7e3)),
        ("placed, scaled by 1e-2 and moved by 1e2", 1e-2, DVec3::new(100.0, 50.0, -100.0)),
    ];
    for (what, s, offset) in placed {
        out.push((what.to_owned(), load_with(&placed_scene(s, offset, width), &octahedron)));
    }
    for distance in [10.0, 20_000.0] {
        for shadows in ["hard", "none"] {
            let what = format!("overhead from {distance}, {shadows} shadows");
            out.push((what, load_with(&overhead_scene(distance, shadows), &octahedron)));
        }
    }
    out.push(("inside a mirror sphere".to_owned(), crate::load(INSIDE_A_MIRROR_SPHERE)));
    out.push(("inside an opaque sphere".to_owned(), crate::load(INSIDE_AN_OPAQUE_SPHERE)));
    for smooth in [false, true] {
        let ball = [("ball.obj", uv_sphere_obj(smooth, 12, 24))];
        out.push((format!("glass mesh of index 1, smooth {smooth}"), load_with(GLASS_MESH_OF_INDEX_ONE, &ball)));
    }
    for s in [1e-3, 1.0, 1e6] {
        out.push((format!("cone scaled by {s:e}"), crate::load(&cone_scene(s))));
    }
    out.push(("smallest scale".to_owned(), crate::load(SMALLEST_SCALE)));
    for s in [1e-3, 1.0, 1e4] {
        out.push((format!("closed room scaled by {s:e}"), crate::load(&closed_room(s))));
    }
    out
}
