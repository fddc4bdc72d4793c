//! `map_Kd` textures (issue 19, item 3): texture coordinates through the
//! loader and its repairs, a texture's mean reaching the solve, the
//! texture's pattern in the image and the glTF export, a missing texture's
//! warning. The textures are small PNGs written here, into a temporary
//! folder.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde_json::Value;
use vkrad::app::{run_scene, Job, Report};
use vkrad::mesh::Mesh;
use vkrad::scene::{load, Scene};
use vkrad::solve::{solve, SolveSettings};

use crate::common;

fn temp_dir(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("tex-{name}"))
}

/// A `w` x `h` PNG whose texel (x, y) (y from the top) is `colour(x, y)`.
fn write_png(path: &Path, w: u32, h: u32, colour: impl Fn(u32, u32) -> [u8; 3]) {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(colour(x, y)));
    img.save(path).unwrap();
}

/// Black on the left half (u < 0.5), white on the right.
fn half_and_half(dir: &Path) {
    write_png(&dir.join("half.png"), 32, 32, |x, _| {
        if x < 16 {
            [0; 3]
        } else {
            [255; 3]
        }
    });
}

/// Four vertical stripes, black, white, black, white (u in quarters).
pub(crate) fn stripes(dir: &Path) {
    write_png(&dir.join("stripes.png"), 64, 8, |x, _| {
        if (x / 16) % 2 == 1 {
            [255; 3]
        } else {
            [0; 3]
        }
    });
}

/// A room: a back wall (z = 0, facing +z, 4 x 4, texture coordinates =
/// (x, y) / 4) whose material is `Kd kd` plus the statement `map`, a grey
/// floor, a ceiling light, open at the front; the camera looks at the wall
/// square on from z = 9.
pub(crate) fn room(dir: &Path, map: &str, kd: f32) -> PathBuf {
    let obj = "\
# vkrad camera eye 2 2 9 look_at 2 2 0 up 0 1 0 fov 30
mtllib room.mtl
v 0 0 0
v 4 0 0
v 4 4 0
v 0 4 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
o wall
usemtl wall
f 1/1 2/2 3/3 4/4
v 0 0 4
v 4 0 4
o floor
usemtl grey
f 1 5 6 2
v 1.5 3.9 1.5
v 2.5 3.9 1.5
v 2.5 3.9 2.5
v 1.5 3.9 2.5
o light
usemtl light
f 7 8 9 10
";
    let mtl = format!(
        "newmtl wall\nKd {kd} {kd} {kd}\n{map}\n\nnewmtl grey\nKd 0.5 0.5 0.5\n\nnewmtl light\nKd 0 0 0\nKe 10 10 10\n"
    );
    std::fs::write(dir.join("room.obj"), obj).unwrap();
    std::fs::write(dir.join("room.mtl"), mtl).unwrap();
    dir.join("room.obj")
}

fn patch_named(scene: &Scene, name: &str) -> u32 {
    scene.patches.iter().position(|p| p.name == name).unwrap() as u32
}

/// A uniform mesh of `scene` solved to 1e-4 with the hemicube.
fn solved(scene: &Scene) -> (Mesh, Vec<[f32; 3]>) {
    let device = common::device();
    let mesh = vkrad::mesh::uniform(scene, 0.5);
    let settings = SolveSettings {
        hemicube_res: 128,
        converge: 1e-4,
        max_shots: 20_000,
        ..Default::default()
    };
    let sol = solve(&device, scene, &mesh, &settings, |_| true).unwrap();
    common::assert_validation_clean(&device);
    (mesh, sol.radiosity)
}

#[test]
fn texture_coordinates_survive_the_repairs() {
    let dir = temp_dir("repairs");
    stripes(&dir);
    // Texture coordinates that are an affine function of the position,
    // so that every corner of every piece must get exactly f(corner).
    let f = |p: Vec3| {
        Vec2::new(
            0.25 * p.x + 0.1 * p.y + 0.05 * p.z,
            0.2 * p.y - 0.1 * p.x + 0.3 * p.z,
        )
    };
    let faces: [&[[f32; 3]]; 4] = [
        // Concave: ear-clipped.
        &[
            [0., 0., 0.],
            [2., 0., 0.],
            [2., 1., 0.],
            [1., 1., 0.],
            [1., 2., 0.],
            [0., 2., 0.],
        ],
        // A bow tie: split where its edges cross, at (3 + 4/3, 2/3).
        &[[3., 0., 0.], [5., 1., 0.], [5., 0., 0.], [3., 2., 0.]],
        // A repeated vertex and one on a straight run: removed.
        &[
            [0., 3., 0.],
            [1., 3., 0.],
            [1., 3., 0.],
            [2., 3., 0.],
            [2., 4., 0.],
            [0., 4., 0.],
        ],
        // Not planar: split in two.
        &[[0., 5., 0.], [1., 5., 0.], [1., 6., 0.3], [0., 6., 0.]],
    ];
    let mut obj = String::from("mtllib t.mtl\nusemtl wall\n");
    let mut n = 0;
    for face in faces {
        let mut f_line = String::from("f");
        for p in face {
            let p3 = Vec3::from_array(*p);
            let uv = f(p3);
            obj += &format!("v {} {} {}\nvt {} {}\n", p[0], p[1], p[2], uv.x, uv.y);
            n += 1;
            f_line += &format!(" {n}/{n}");
        }
        obj += &f_line;
        obj += "\n";
    }
    obj += "usemtl light\nv 0 9 0\nv 1 9 0\nv 0 9 1\nf -3 -2 -1\n";
    std::fs::write(dir.join("t.obj"), obj).unwrap();
    std::fs::write(
        dir.join("t.mtl"),
        "newmtl wall\nKd 1 1 1\nmap_Kd stripes.png\nnewmtl light\nKe 1 1 1\n",
    )
    .unwrap();
    let s = load(&dir.join("t.obj")).unwrap();
    for kind in [
        "concave",
        "self-intersecting",
        "repeated",
        "straight",
        "non-planar",
    ] {
        assert!(
            s.warnings.iter().any(|w| w.contains(kind)),
            "no {kind} repair in {:?}",
            s.warnings
        );
    }
    let textured: Vec<_> = s.patches.iter().filter(|p| p.texture.is_some()).collect();
    assert!(textured.len() >= 4 + 2 + 1 + 2, "{} pieces", textured.len());
    let mut crossing = false;
    for p in &textured {
        assert_eq!(p.uv.len(), p.vertices.len());
        for (v, uv) in p.vertices.iter().zip(&p.uv) {
            assert!((*uv - f(*v)).length() < 1e-5, "{v}: {uv} against {}", f(*v));
            assert!((p.uv_at(*v).unwrap() - f(*v)).length() < 1e-5);
            crossing |= v.distance(Vec3::new(3.0 + 4.0 / 3.0, 2.0 / 3.0, 0.0)) < 1e-5;
        }
        // Inside too (the pieces are triangles or planar convex polygons
        // where f is affine).
        let c = p.centroid();
        assert!((p.uv_at(c).unwrap() - f(c)).length() < 1e-5);
    }
    assert!(crossing, "the bow tie's crossing point is a corner");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_or_unreadable_texture_is_a_warning_at_its_line() {
    let dir = temp_dir("missing");
    // room.mtl's line 3 is the map_Kd statement.
    let s = load(&room(&dir, "map_Kd nowhere.png", 0.8)).unwrap();
    let warning = s
        .warnings
        .iter()
        .find(|w| w.contains("cannot read texture"))
        .expect("a warning");
    let mtl = dir.join("room.mtl");
    assert!(
        warning.starts_with(&format!(
            "{}:3: cannot read texture \"nowhere.png\"",
            mtl.display()
        )),
        "{warning}"
    );
    assert!(warning.ends_with("using Kd alone"), "{warning}");
    assert!(s.textures.is_empty());
    let wall = patch_named(&s, "wall");
    assert_eq!(s.patches[wall as usize].texture, None);
    assert_eq!(s.patch_reflectances()[wall as usize], Vec3::splat(0.8));

    // Bytes that are no image: the same warning, with the decoder's reason.
    std::fs::write(dir.join("broken.png"), b"not a png at all").unwrap();
    let s = load(&room(&dir, "map_Kd broken.png", 0.8)).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.starts_with(&format!(
            "{}:3: cannot read texture \"broken.png\"",
            mtl.display()
        ))),
        "{:?}",
        s.warnings
    );
    assert!(s.textures.is_empty());

    // A face of a textured material without texture coordinates: Kd alone,
    // and a warning that says so.
    half_and_half(&dir);
    let obj = std::fs::read_to_string(dir.join("room.obj"))
        .unwrap()
        .replace("f 1/1 2/2 3/3 4/4", "f 1 2 3 4");
    std::fs::write(dir.join("room.obj"), obj).unwrap();
    std::fs::write(
        dir.join("room.mtl"),
        "newmtl wall\nKd 0.8 0.8 0.8\nmap_Kd half.png\n\nnewmtl grey\nKd 0.5 0.5 0.5\n\nnewmtl light\nKe 10 10 10\n",
    )
    .unwrap();
    let s = load(&dir.join("room.obj")).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("1 face of a textured material without texture coordinates")),
        "{:?}",
        s.warnings
    );
    assert!(s.patches.iter().all(|p| p.texture.is_none()));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_texture_s_mean_reaches_the_solve() {
    let dir = temp_dir("mean");
    half_and_half(&dir);
    // Kd 0.8 times a half-black, half-white texture (clamped: no wrap-around
    // at its edges) against a plain wall of Kd 0.4, its mean.
    let textured = load(&room(&dir, "map_Kd -clamp on half.png", 0.8)).unwrap();
    let plain = load(&room(&dir, "", 0.4)).unwrap();
    let bright = load(&room(&dir, "", 0.8)).unwrap();
    assert!(textured.warnings.is_empty(), "{:?}", textured.warnings);
    let wall = patch_named(&textured, "wall");
    let rho = textured.patch_reflectances()[wall as usize];
    assert!((rho - Vec3::splat(0.4)).abs().max_element() < 1e-3, "{rho}");

    let (mesh, b_tex) = solved(&textured);
    let (_, b_plain) = solved(&plain);
    let (_, b_bright) = solved(&bright);
    // The light the wall reflects, in all.
    let reflected = |b: &[[f32; 3]]| -> f64 {
        mesh.elements
            .iter()
            .zip(b)
            .filter(|(e, _)| e.patch == wall)
            .map(|(e, b)| f64::from(b[0]) * f64::from(e.area))
            .sum()
    };
    let (t, p, w) = (reflected(&b_tex), reflected(&b_plain), reflected(&b_bright));
    eprintln!("wall's reflected power: textured {t:.4}, Kd 0.4 {p:.4}, Kd 0.8 {w:.4}");
    assert!(
        (t / p - 1.0).abs() < 0.01,
        "textured {t} against Kd 0.4's {p}"
    );
    assert!(w / p > 1.9, "Kd 0.8 {w} against 0.4 {p}");
    // Element by element: black where the texture is, twice the plain
    // wall's where it is white (the irradiance is about the same: near the
    // floor a little more, as the floor in front of the white half gets
    // more of the wall's light back).
    let (mut black, mut white, mut worst) = (0, 0, 0.0f32);
    for (i, e) in mesh.elements.iter().enumerate() {
        if e.patch != wall {
            continue;
        }
        if e.centre.x < 1.5 {
            assert!(
                b_tex[i][0].abs() < 1e-6,
                "element {i} at {}: {:?}",
                e.centre,
                b_tex[i]
            );
            black += 1;
        } else if e.centre.x > 2.5 {
            let ratio = b_tex[i][0] / b_plain[i][0];
            if e.centre.y > 1.0 {
                worst = worst.max((ratio - 2.0).abs());
            }
            let tolerance = if e.centre.y > 1.0 { 0.04 } else { 0.1 };
            assert!(
                (ratio - 2.0).abs() < tolerance,
                "element {i} at {}: {ratio}",
                e.centre
            );
            white += 1;
        }
    }
    eprintln!(
        "{black} black elements, {white} white ones; above y = 1 within {worst:.3} of twice the plain wall's"
    );
    assert!(black >= 16 && white >= 16, "{black} black, {white} white");
    std::fs::remove_dir_all(&dir).ok();
}

/// The room rendered at 96 x 96 (and exported to `NAME.glb`) by the
/// default pipeline (final gather on a discontinuity display mesh).
fn render(dir: &Path, scene: Scene, name: &str) -> Report {
    let device = common::device();
    let mut job = Job::new(name);
    job.output = Some(dir.join(format!("{name}.png")));
    job.export = Some(dir.join(format!("{name}.glb")));
    job.size = (96, 96);
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    report
}

/// Texture coordinate u of the wall at pixel column `x` of the middle row
/// (the camera of `room`: from z = 9, 30 degrees, square).
pub(crate) fn u_at_column(x: u32, width: u32) -> f32 {
    let ndc = (x as f32 + 0.5) / (width as f32 * 0.5) - 1.0;
    (2.0 + ndc * 9.0 * 15f32.to_radians().tan()) / 4.0
}

#[test]
fn the_image_and_the_gltf_show_the_texture_lit_by_the_solve() {
    let dir = temp_dir("image");
    stripes(&dir);
    let textured = render(
        &dir,
        load(&room(&dir, "map_Kd stripes.png", 0.8)).unwrap(),
        "textured",
    );
    let plain = render(&dir, load(&room(&dir, "", 0.4)).unwrap(), "plain");
    let (w, h) = (textured.image.width, textured.image.height);
    let row = h / 2;
    let pixel = |r: &Report, x: u32| Vec3::from(r.image.pixels[(row * w + x) as usize]);
    let (mut on, mut off) = (0, 0);
    for x in 0..w {
        let u = u_at_column(x, w);
        let edge = (u * 4.0 - (u * 4.0).round()).abs() / 4.0;
        if !(0.0..1.0).contains(&u) || edge < 0.03 {
            continue;
        }
        let (t, p) = (pixel(&textured, x), pixel(&plain, x));
        if ((u * 4.0) as u32) % 2 == 1 {
            // White texels: Kd x irradiance, twice the plain wall's Kd 0.4
            // x the same irradiance.
            let ratio = t.x / p.x;
            assert!((ratio - 2.0).abs() < 0.06, "column {x} (u {u}): {ratio}");
            on += 1;
        } else {
            assert!(
                t.max_element() < 1e-3 * p.x,
                "column {x} (u {u}): {t} where black"
            );
            off += 1;
        }
    }
    assert!(on >= 20 && off >= 20, "{on} white and {off} black columns");

    // The glTF: the wall's primitive carries the texture and coordinates.
    let bytes = std::fs::read(dir.join("textured.glb")).unwrap();
    let (json, bin) = crate::export::read_glb(&bytes);
    let images = json["images"].as_array().expect("images");
    assert_eq!(images.len(), 1);
    assert_eq!(images[0]["mimeType"], "image/png");
    let view = &json["bufferViews"][images[0]["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap() as usize;
    let png = &bin[at..at + view["byteLength"].as_u64().unwrap() as usize];
    let decoded = image::load_from_memory(png).unwrap().to_rgb8();
    let original = image::open(dir.join("stripes.png")).unwrap().to_rgb8();
    assert_eq!(decoded, original);
    let primitives = json["meshes"][0]["primitives"].as_array().unwrap();
    assert_eq!(primitives.len(), 2, "untextured and textured");
    let with_texture: Vec<&Value> = primitives
        .iter()
        .filter(|p| !p["attributes"]["TEXCOORD_0"].is_null())
        .collect();
    assert_eq!(with_texture.len(), 1);
    let material = &json["materials"][with_texture[0]["material"].as_u64().unwrap() as usize];
    assert_eq!(
        material["pbrMetallicRoughness"]["baseColorTexture"]["index"],
        0
    );
    // Texture coordinates at the wall's vertices: (x / 4, 1 - y / 4) (glTF
    // counts v from the image's top).
    let read_floats = |index: &Value, width: usize| -> Vec<f32> {
        let a = &json["accessors"][index.as_u64().unwrap() as usize];
        let v = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let at = v["byteOffset"].as_u64().unwrap() as usize;
        let n = a["count"].as_u64().unwrap() as usize * width;
        bin[at..at + 4 * n]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    let uv = read_floats(&with_texture[0]["attributes"]["TEXCOORD_0"], 2);
    let positions = read_floats(&with_texture[0]["attributes"]["POSITION"], 3);
    let mesh = textured.display_mesh.as_ref().unwrap_or(&textured.mesh);
    let wall = patch_named(&textured.scene, "wall");
    let mut checked = 0;
    for e in mesh.elements.iter().filter(|e| e.patch == wall) {
        for &c in e.corners() {
            let c = c as usize;
            let (x, y) = (positions[3 * c], positions[3 * c + 1]);
            assert!(
                (uv[2 * c] - x / 4.0).abs() < 1e-5
                    && (uv[2 * c + 1] - (1.0 - y / 4.0)).abs() < 1e-5
            );
            checked += 1;
        }
    }
    assert!(checked > 0);
    std::fs::remove_dir_all(&dir).ok();
}
