use std::path::PathBuf;

use glam::Vec3;

use super::*;
use crate::error::SourceLocation;

const MTL: &str = "newmtl white\nKd 0.5 0.5 0.5\n\nnewmtl light\nKd 0 0 0\nKe 1 1 1\n";
/// An emitter to append to test scenes (uses relative indices).
const LIGHT: &str = "o lamp\nusemtl light\nv 0 5 0\nv 1 5 0\nv 0 5 1\nf -3 -2 -1\n";

fn load_with(obj: &str, mtl: &str) -> Result<Scene> {
    let mtl = mtl.to_owned();
    load_from_str("t.obj", obj, move |name| {
        (name == "t.mtl").then(|| mtl.clone())
    })
}

/// `obj` (which should `mtllib t.mtl`) plus the light, with the standard MTL.
fn load_obj(obj: &str) -> Result<Scene> {
    load_with(&format!("{obj}{LIGHT}"), MTL)
}

/// The location, message and hint of a scene error.
fn scene_err(r: Result<Scene>) -> (SourceLocation, String, Option<String>) {
    match r {
        Err(Error::Scene { at, what, hint }) => (at, what, hint),
        Err(e) => panic!("expected a scene error, got {e}"),
        Ok(s) => panic!("expected a scene error, got a scene: {:?}", s.warnings),
    }
}

fn assert_err_at(r: Result<Scene>, file: &str, line: usize, contains: &str) {
    let (at, what, hint) = scene_err(r);
    assert_eq!(at.file, PathBuf::from(file), "{what}");
    assert_eq!(at.line, line, "{what}");
    assert!(what.contains(contains), "{what:?} lacks {contains:?}");
    assert!(hint.is_some(), "no hint for {what}");
}

#[test]
fn cornell_loads_cleanly() {
    let s = load_builtin("cornell").unwrap().unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.name, "cornell");
    assert_eq!(s.source, PathBuf::from("builtin:cornell"));
    // 5 room faces, the light, and 5 faces per block.
    assert_eq!(s.patches.len(), 16);
    assert!(s
        .patches
        .iter()
        .all(|p| p.area > 0.0 && p.vertices.len() == 4));
    let light: Vec<&Patch> = s
        .patches
        .iter()
        .filter(|p| s.material_of(p).is_emitter())
        .collect();
    assert_eq!(light.len(), 1);
    assert_eq!(light[0].name, "light");
    assert!((light[0].area - 130.0 * 105.0).abs() < 0.5);
    assert!(light[0].normal.abs_diff_eq(-Vec3::Y, 1e-6));
    assert!(light[0].vertices.iter().all(|v| v.y == 548.7));
    let m = s.material_of(light[0]);
    assert_eq!(m.emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!(m.reflectance, Vec3::splat(0.78));
    let cam = s.camera.unwrap();
    assert_eq!(cam.eye, Vec3::new(278.0, 273.0, -800.0));
    assert_eq!(cam.look_at, Vec3::new(278.0, 273.0, 0.0));
    assert_eq!(cam.up, Vec3::Y);
    assert!((cam.fov_y_deg - 39.3077).abs() < 1e-4);
    let colour = |name: &str| {
        let p = s.patches.iter().find(|p| p.name == name).unwrap();
        s.material_of(p).reflectance
    };
    assert_eq!(colour("left_wall"), Vec3::new(0.63, 0.065, 0.05));
    assert_eq!(colour("right_wall"), Vec3::new(0.14, 0.45, 0.091));
    assert_eq!(colour("floor"), Vec3::splat(0.73));
    let (lo, hi) = s.bounds();
    assert!(lo.abs_diff_eq(Vec3::ZERO, 1e-6));
    assert!(hi.abs_diff_eq(Vec3::new(556.0, 548.8, 559.2), 1e-3));
}

#[test]
fn cornell_normals_face_the_room() {
    let s = load_builtin("cornell").unwrap().unwrap();
    let room_centre = Vec3::new(278.0, 274.4, 279.6);
    let block_centre = |name: &str| {
        let v: Vec<Vec3> = s
            .patches
            .iter()
            .filter(|p| p.name == name)
            .flat_map(|p| p.vertices.iter().copied())
            .collect();
        v.iter().copied().sum::<Vec3>() / v.len() as f32
    };
    let mut seen = 0;
    for p in &s.patches {
        assert!((p.normal.length() - 1.0).abs() < 1e-5);
        // CCW around the normal.
        let n = (p.vertices[1] - p.vertices[0]).cross(p.vertices[2] - p.vertices[1]);
        assert!(n.dot(p.normal) > 0.0, "{}", p.name);
        let c = p.centroid();
        match p.name.as_str() {
            "floor" | "ceiling" | "back_wall" | "left_wall" | "right_wall" | "light" => {
                assert!(p.normal.dot(room_centre - c) > 0.0, "{} faces out", p.name);
            }
            "short_block" | "tall_block" => {
                let away = c - block_centre(&p.name);
                assert!(p.normal.dot(away) > 0.0, "{} faces in", p.name);
            }
            other => panic!("unexpected patch {other}"),
        }
        seen += 1;
    }
    assert_eq!(seen, 16);
    let axis = |name: &str| s.patches.iter().find(|p| p.name == name).unwrap().normal;
    assert!(axis("floor").abs_diff_eq(Vec3::Y, 1e-6));
    assert!(axis("ceiling").abs_diff_eq(-Vec3::Y, 1e-6));
    assert!(axis("back_wall").abs_diff_eq(-Vec3::Z, 1e-6));
    assert!(axis("left_wall").x < -0.99);
    assert!(axis("right_wall").abs_diff_eq(Vec3::X, 1e-6));
}

#[test]
fn simple_loads() {
    let s = load_builtin("simple").unwrap().unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.patches.len(), 3);
    let by_name = |n: &str| s.patches.iter().find(|p| p.name == n).unwrap();
    assert!(by_name("floor").normal.abs_diff_eq(Vec3::Y, 1e-6));
    assert!((by_name("floor").area - 100.0).abs() < 1e-4);
    assert!(by_name("blocker").normal.abs_diff_eq(Vec3::Y, 1e-6));
    let light = by_name("light");
    assert!(light.normal.abs_diff_eq(-Vec3::Y, 1e-6));
    assert_eq!(s.material_of(light).emission, Vec3::splat(10.0));
    assert!(s.camera.is_some());
    assert!(s.emitted_power().x > 0.0);
}

#[test]
fn builtins_and_scene_args() {
    assert_eq!(
        builtin_names(),
        ["cornell", "simple", "r", "vise", "rfield"]
    );
    for name in builtin_names() {
        assert!(load_builtin(name).unwrap().is_ok());
    }
    assert!(load_builtin("nope").is_none());
    assert_eq!(load_scene_arg("cornell").unwrap().name, "cornell");
    assert_eq!(load_scene_arg("builtin:simple").unwrap().name, "simple");
    match load_scene_arg("/no/such/dir/scene.obj") {
        Err(Error::Io {
            path,
            cause: source,
        }) => {
            assert_eq!(path, PathBuf::from("/no/such/dir/scene.obj"));
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
            let msg = source.to_string();
            assert!(
                msg.contains("no such file") && msg.contains("cornell, simple"),
                "{msg}"
            );
        }
        other => panic!("expected an io error, got {other:?}"),
    }
}

/// A fresh directory for file tests.
fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vkrad-scene-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn loads_files_and_reports_missing_mtl() {
    let dir = temp_dir("files");
    let obj = dir.join("box.obj");
    std::fs::write(
        &obj,
        format!("mtllib box.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{LIGHT}"),
    )
    .unwrap();
    std::fs::write(dir.join("box.mtl"), MTL).unwrap();
    let s = load(&obj).unwrap();
    assert_eq!(s.name, "box");
    assert_eq!(s.patches.len(), 2);
    assert_eq!(s.patches[0].line, 6);
    assert_eq!(s.patches[1].line, 12);
    // Through the argument parser too.
    assert_eq!(
        load_scene_arg(obj.to_str().unwrap()).unwrap().patches.len(),
        2
    );

    std::fs::remove_file(dir.join("box.mtl")).unwrap();
    let (at, what, hint) = scene_err(load(&obj));
    assert_eq!(at.file, obj);
    assert_eq!(at.line, 1);
    assert!(
        what.contains("box.mtl") && what.contains("not found"),
        "{what}"
    );
    assert!(hint.unwrap().contains("mtllib"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn missing_mtl_from_str() {
    let obj = "mtllib other.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_err_at(load_with(obj, MTL), "t.obj", 1, "\"other.mtl\" not found");
}

#[test]
fn nan_and_infinite_vertices() {
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_err_at(load_obj(obj), "t.obj", 4, "not a finite number");
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n";
    assert_err_at(load_obj(obj), "t.obj", 5, "not a finite number");
    let obj = "mtllib t.mtl\nv 0 0 x\n";
    assert_err_at(load_obj(obj), "t.obj", 2, "not a number");
    let obj = "mtllib t.mtl\n\nv 0 0\n";
    assert_err_at(load_obj(obj), "t.obj", 3, "needs 3 coordinates");
    let obj = "mtllib t.mtl\nv 0 0 0 0\n";
    assert_err_at(load_obj(obj), "t.obj", 2, "weight");
}

#[test]
fn bad_face_references() {
    let head = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    assert_err_at(
        load_obj(&format!("{head}f 1 2 4\n")),
        "t.obj",
        6,
        "out of range",
    );
    assert_err_at(
        load_obj(&format!("{head}f 1 2 -4\n")),
        "t.obj",
        6,
        "out of range",
    );
    assert_err_at(
        load_obj(&format!("{head}\nf 0 1 2\n")),
        "t.obj",
        7,
        "index 0",
    );
    assert_err_at(
        load_obj(&format!("{head}f 1 2\n")),
        "t.obj",
        6,
        "at least 3",
    );
    assert_err_at(
        load_obj(&format!("{head}f 1 a 2\n")),
        "t.obj",
        6,
        "not a vertex index",
    );
    let huge = format!("{head}f 1 2 -9223372036854775808\n");
    assert_err_at(load_obj(&huge), "t.obj", 6, "out of range");
    // A face may only use vertices defined above it.
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n";
    assert_err_at(load_obj(obj), "t.obj", 5, "out of range");
    // Relative indices and v/vt/vn forms are fine.
    let s = load_obj(&format!("{head}vt 0 0\nvn 0 0 1\nf -3/1/1 -2//1 -1/1\n")).unwrap();
    assert_eq!(s.patches[0].line, 8);
    assert!(s.patches[0].normal.abs_diff_eq(Vec3::Z, 1e-6));
}

/// The warning line of the given start, exactly one.
fn warning<'a>(s: &'a Scene, start: &str) -> &'a str {
    let w: Vec<&String> = s.warnings.iter().filter(|w| w.starts_with(start)).collect();
    assert_eq!(w.len(), 1, "{start:?} in {:?}", s.warnings);
    w[0]
}

#[test]
fn degenerate_faces_are_dropped_with_one_warning() {
    // Collinear, two distinct vertices, one point, and a sliver 1e-9 wide
    // (zero next to the scene, whose light is 5 away): all dropped, one
    // line that counts them and lists the first three.
    let head =
        "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 1 1\nv 2 2 2\nv 1 0 0\nv 0.5 1e-9 0\nv 0 1 0\n";
    let faces = "f 1 2 3\nf 1 4 4\n# c\nf 1 1 1\nf 1 4 5\nf 1 4 6\n";
    let s = load_obj(&format!("{head}{faces}")).unwrap();
    let w = warning(&s, "dropped 4 zero-area faces (");
    assert!(
        w.starts_with("dropped 4 zero-area faces (t.obj:9, :10, :12, ...): "),
        "{w}"
    );
    // The good face and the light are left.
    assert_eq!(s.patches.len(), 2);
    assert_eq!(s.patches[0].line, 14);
    // Without the good face: nothing of the floor is left, the light is.
    let s = load_obj(&format!("{head}f 1 2 3\n")).unwrap();
    assert_eq!(warning(&s, "dropped 1 zero-area face ("), s.warnings[0]);
    assert!(s.warnings[0].starts_with("dropped 1 zero-area face (t.obj:9): "));
    // Only degenerate faces: an error naming them.
    let obj = "mtllib t.mtl\nusemtl light\nv 0 0 0\nv 1 0 0\nf 1 2 2\nf 2 1 1\n";
    assert_err_at(load_with(obj, MTL), "t.obj", 0, "dropped (t.obj:5, :6)");
}

#[test]
fn coincident_faces_are_dropped_and_opposite_ones_kept() {
    // A floor quad, the same quad from another starting vertex (with its own
    // `v` lines, a hair apart), and the quad reversed (its back).
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 4 3 2\n\
               v 1 0 1.0000000001\nv 0 0 1\nv 0 0 0\nv 1 0 0\nf -3 -4 -1 -2\n\
               f 1 2 3 4\n";
    let s = load_obj(obj).unwrap();
    let w = warning(&s, "dropped 1 face that coincides");
    assert!(
        w.starts_with("dropped 1 face that coincides with another face (t.obj:12 (copy of :7)): "),
        "{w}"
    );
    let floor: Vec<&Patch> = s
        .patches
        .iter()
        .filter(|p| !s.material_of(p).is_emitter())
        .collect();
    assert_eq!(floor.len(), 2);
    assert!(floor[0].normal.abs_diff_eq(Vec3::Y, 1e-6));
    assert!(floor[1].normal.abs_diff_eq(-Vec3::Y, 1e-6));
    // Of a light and a wall on the same polygon, the light stays.
    let obj =
        "mtllib t.mtl\nusemtl white\nv 0 5 0\nv 0 5 1\nv 1 5 0\nf 1 2 3\nusemtl light\nf 2 3 1\n\
               usemtl white\nv 0 0 0\nv 0 0 1\nv 1 0 0\nf -3 -2 -1\n";
    let s = load_with(obj, MTL).unwrap();
    assert!(
        warning(&s, "dropped 1 face that coincides").contains("(t.obj:6 (copy of :8))"),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.patches.len(), 2);
    assert!(s.material_of(&s.patches[0]).is_emitter());
}

#[test]
fn bow_tie_is_split_into_two_triangles() {
    // The scan's bow tie: edges 2-3 and 4-1 cross at (1, 0.5, 0).
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 2 0 0\nv 0 1 0\nv 2 1 0\nf 1 2 3 4\n";
    let s = load_obj(obj).unwrap();
    let w = warning(
        &s,
        "split 1 self-intersecting face into 2 simple pieces (t.obj:7)",
    );
    assert!(w.contains("bow tie"), "{w}");
    let tie: Vec<&Patch> = s.patches.iter().filter(|p| p.line == 7).collect();
    assert_eq!(tie.len(), 2);
    let area: f32 = tie.iter().map(|p| p.area).sum();
    // Two triangles of base 1 and height 1/2... each 0.5 wide at x = 0, 2.
    assert!((area - 1.0).abs() < 1e-6, "{area}");
    for p in &tie {
        assert_eq!(p.vertices.len(), 3);
        assert!(p
            .vertices
            .iter()
            .any(|v| v.abs_diff_eq(Vec3::new(1.0, 0.5, 0.0), 1e-6)));
        assert_eq!(p.normal, tie[0].normal);
    }
}

#[test]
fn line_and_point_elements_are_skipped() {
    let obj =
        "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3 1\np 1\nf 1 2 3\n";
    let s = load_obj(obj).unwrap();
    assert!(warning(&s, "skipped 2 line elements (`l`) (t.obj:6, :7)").contains("only faces"));
    assert!(warning(&s, "skipped 1 point element (`p`) (t.obj:8)").contains("only faces"));
    assert_eq!(s.patches.len(), 2);
}

#[test]
fn stray_mtl_lines_warn() {
    let obj = format!("mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{LIGHT}");
    let mtl = "Kd 1 1 1\nnewmtl white\nKd 0.5 0.5 0.5\n  v .1 0 0\nfoo bar\nmap_Kd a.png\nNs 10\nnewmtl light\nKd 0\nKe 1 1 1\n";
    let s = load_with(&obj, mtl).unwrap();
    assert_eq!(
        warning(&s, "ignored 1 statement before"),
        "ignored 1 statement before the first `newmtl` (t.mtl:1 `Kd`): they belong to no material"
    );
    assert_eq!(
        warning(&s, "ignored 2 unknown"),
        "ignored 2 unknown statements (t.mtl:4 `v`, :5 `foo`): not MTL statements vkrad knows"
    );
    // A texture that is not there: a warning at its line, and Kd alone.
    assert!(warning(&s, "t.mtl:6: cannot read texture \"a.png\"").ends_with("using Kd alone"));
    assert!(s.textures.is_empty() && s.patches.iter().all(|p| p.texture.is_none()));
    assert_eq!(s.warnings.len(), 3, "{:?}", s.warnings);
}

#[test]
fn specular_materials_warn_once_each() {
    let obj = format!(
        "mtllib t.mtl\nusemtl mirror\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl glass\nf 1 3 2\n\
         usemtl shiny\nv 0 0 1\nf 1 2 -1\nusemtl paint\nf 1 -1 2\n{LIGHT}"
    );
    let mtl = "newmtl mirror\nKd 0.01 0.01 0.01\nKs 0.95 0.95 0.95\nillum 5\n\
               newmtl glass\nKd 0.01\nKs 0.3\nTf 0.1 0.1 0.1\nNi 2.5\nillum 7\n\
               newmtl shiny\nKd 0.2\nKs 0.6\nillum 2\n\
               newmtl paint\nKd 0.8\nKs 0.5\nNi 1.5\nillum 2\nTf 1 1 1\nd 1\n\
               newmtl unused\nKs 1\nillum 3\n\
               newmtl light\nKd 0\nKe 1 1 1\n";
    let s = load_with(&obj, mtl).unwrap();
    let w: Vec<&String> = s.warnings.iter().filter(|w| w.contains("\" is ")).collect();
    assert_eq!(w.len(), 3, "{:?}", s.warnings);
    assert_eq!(
        w[0],
        "t.mtl:1: material \"mirror\" is a mirror (illum 5, Ks 0.95): vkrad treats it as opaque and diffuse with its Kd 0.01: with so dark a Kd it will look almost black"
    );
    assert!(
        w[1].starts_with("t.mtl:5: material \"glass\" is transparent (illum 7, Tf 0.1, Ni 2.5, Ks 0.3): vkrad treats it as opaque and diffuse with its Kd 0.01"),
        "{}",
        w[1]
    );
    assert!(
        w[2].starts_with("t.mtl:11: material \"shiny\" is shiny (Ks 0.6): vkrad treats it as opaque and diffuse with its Kd 0.2"),
        "{}",
        w[2]
    );
    // And nothing else but the unused material's missing Kd.
    assert_eq!(s.warnings.len(), 4, "{:?}", s.warnings);
}

#[test]
fn no_emitter_names_the_materials_that_look_like_lights() {
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl Ceiling_Lamp\nf 1 3 2\n";
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nKa 1 1 1\nnewmtl Ceiling_Lamp\nKd 0.8\n";
    let (at, what, hint) = scene_err(load_with(obj, mtl));
    assert_eq!(at.line, 0);
    assert_eq!(
        what,
        "no emitter: no material has a positive Ke, but \"Ceiling_Lamp\" (t.mtl:4: its name) looks like a light"
    );
    assert!(hint.unwrap().contains("`Ke` line after its `newmtl` line"));
    // Ambient brighter than diffuse, and illum 0, are hints too.
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nKa 4 4 4\nnewmtl Ceiling_Lamp\nKd 0.8\n";
    let obj = obj.replace("Ceiling_Lamp", "flat");
    let (_, what, _) = scene_err(load_with(
        &obj,
        &mtl.replace("Ceiling_Lamp", "flat\nillum 0"),
    ));
    assert!(
        what.contains("\"white\" (t.mtl:1: Ka 4 is brighter than its Kd)"),
        "{what}"
    );
    assert!(
        what.contains("\"flat\" (t.mtl:4: illum 0, an unlit constant colour)"),
        "{what}"
    );
    assert!(what.ends_with("look like lights"), "{what}");
}

#[test]
fn tolerances_follow_the_scene_size() {
    // A millimetre-sized scene: a face 1e-5 across is a face there...
    let small = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1e-5 0 0\nv 0 1e-5 0\nf 1 2 3\n\
                 usemtl light\nv 0 1e-3 0\nv 1e-3 1e-3 0\nv 0 1e-3 1e-3\nf -3 -2 -1\n";
    let s = load_with(small, MTL).unwrap();
    assert_eq!(s.patches.len(), 2, "{:?}", s.warnings);
    // ...and a speck in a 100 m hall.
    let big = small.replace("1e-3", "100");
    let s = load_with(&big, MTL).unwrap();
    assert_eq!(s.patches.len(), 1);
    assert!(warning(&s, "dropped 1 zero-area face (t.obj:6)").contains("1e-6 of the scene's size"));
}

#[test]
fn non_planar_quad_is_split_with_warning() {
    let obj =
        "mtllib t.mtl\nusemtl white\no roof\nv 0 0 0\nv 1 0 0\nv 1 1 0.3\nv 0 1 0\nf 1 2 3 4\n";
    let s = load_obj(obj).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].starts_with(
            "split 1 non-planar quad into 2 triangles (t.obj:8; largest deviation from a plane 0.07"
        ),
        "{}",
        s.warnings[0]
    );
    let roof: Vec<&Patch> = s.patches.iter().filter(|p| p.name == "roof").collect();
    assert_eq!(roof.len(), 2);
    let mut area = 0.0;
    for p in &roof {
        assert_eq!(p.line, 8);
        assert_eq!(p.vertices.len(), 3);
        assert!(p.normal.z > 0.9);
        let n = (p.vertices[1] - p.vertices[0]).cross(p.vertices[2] - p.vertices[0]);
        assert!(n.normalize().abs_diff_eq(p.normal, 1e-5));
        assert!((n.length() / 2.0 - p.area).abs() < 1e-5);
        area += p.area;
    }
    // The folded surface: slightly more than its unit-square shadow.
    assert!(area > 1.0 && area < 1.05, "{area}");
}

#[test]
fn concave_polygon_is_split_with_warning() {
    // An L shape of area 3 facing +z, and a small tilt within tolerance.
    let obj = "mtllib t.mtl\nusemtl white\ng ell\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0.0005\nv 0 2 0\nf 1 2 3 4 5 6\n";
    let s = load_obj(obj).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_eq!(
        s.warnings[0],
        "split 1 concave polygon into 4 triangles (t.obj:10)"
    );
    let ell: Vec<&Patch> = s.patches.iter().filter(|p| p.name == "ell").collect();
    assert_eq!(ell.len(), 4);
    let area: f32 = ell.iter().map(|p| p.area).sum();
    assert!((area - 3.0).abs() < 1e-3, "{area}");
    for p in &ell {
        assert_eq!(p.line, 10);
        assert!(p.normal.z > 0.999);
        let n = (p.vertices[1] - p.vertices[0]).cross(p.vertices[2] - p.vertices[0]);
        assert!(n.dot(p.normal) > 0.0);
    }
    // All pieces lie in one plane.
    let n = ell[0].normal;
    let d = n.dot(ell[0].vertices[0]);
    for v in ell.iter().flat_map(|p| p.vertices.iter()) {
        assert!((n.dot(*v) - d).abs() < 1e-5);
    }
}

#[test]
fn material_errors() {
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let r = load_with(
        &format!("{obj}{LIGHT}"),
        "newmtl white\nKd 0.5 1.2 0.5\nnewmtl light\nKe 1 1 1\nKd 0 0 0\n",
    );
    assert_err_at(r, "t.mtl", 2, "outside [0, 1]");
    let r = load_with(
        &format!("{obj}{LIGHT}"),
        "newmtl white\nKd -0.1 0.5 0.5\nnewmtl light\nKe 1 1 1\nKd 0 0 0\n",
    );
    assert_err_at(r, "t.mtl", 2, "outside [0, 1]");
    let r = load_with(
        &format!("{obj}{LIGHT}"),
        "newmtl white\nKd 0.5 0.5 0.5\nnewmtl light\n\nKe 1 -1 1\n",
    );
    assert_err_at(r, "t.mtl", 5, "negative");
    let r = load_with(
        &format!("{obj}{LIGHT}"),
        "newmtl white\nKd 0.5 0.5 0.5\nnewmtl light\nKe 1 inf 1\n",
    );
    assert_err_at(r, "t.mtl", 4, "not finite");
    let r = load_with(&format!("{obj}{LIGHT}"), "newmtl white\nKd 0.5 0.5\n");
    assert_err_at(r, "t.mtl", 2, "needs 3 numbers");
    let r = load_with(
        &format!("{obj}{LIGHT}"),
        "newmtl white\nKd spectral a.spd\n",
    );
    assert_err_at(r, "t.mtl", 2, "not a number");
    let r = load_with(&format!("{obj}{LIGHT}"), "newmtl white\nnewmtl white\n");
    assert_err_at(r, "t.mtl", 2, "defined twice");
    // Unknown material: reported at the usemtl line.
    let r = load_with(
        &format!("{obj}\nusemtl lamp\nv 0 5 0\nv 1 5 0\nv 0 5 1\nf -3 -2 -1\n"),
        MTL,
    );
    assert_err_at(r, "t.obj", 8, "unknown material \"lamp\"");
    // usemtl without any mtllib.
    let r = load_with("usemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", MTL);
    assert_err_at(r, "t.obj", 1, "no `mtllib`");
}

#[test]
fn material_defaults_and_warnings() {
    // Missing Kd: grey with a warning; single-value Kd and Ke are expanded.
    let obj = format!("mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{LIGHT}");
    let s = load_with(
        &obj,
        "newmtl white\nNs 10\nillum 2\nnewmtl light\nKd 0.25\nKe 3\n",
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].starts_with("t.mtl:1: material \"white\" has no Kd"));
    assert_eq!(s.material_of(&s.patches[0]).reflectance, Vec3::splat(0.5));
    assert_eq!(s.material_of(&s.patches[1]).reflectance, Vec3::splat(0.25));
    assert_eq!(s.material_of(&s.patches[1]).emission, Vec3::splat(3.0));

    // A face with no material: default grey, with a warning naming its line.
    let obj = format!("mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{LIGHT}");
    let s = load_with(&obj, MTL).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].starts_with("t.obj:5: 1 face(s) have no material"));
    let m = s.material_of(&s.patches[0]);
    assert_eq!(m.reflectance, Vec3::splat(0.5));
    assert!(!m.is_emitter());
}

#[test]
fn no_emitter_and_empty_scene() {
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let (at, what, hint) = scene_err(load_with(obj, "newmtl white\nKd 0.5 0.5 0.5\n"));
    assert_eq!(at.line, 0);
    assert_eq!(what, "no emitter: no material has a positive Ke");
    assert!(hint.unwrap().contains("Ke 10 10 10"));
    // An emitter material that no face uses.
    let (_, what, _) = scene_err(load_with(obj, MTL));
    assert!(
        what.contains("\"light\" has a positive Ke but no face uses it"),
        "{what}"
    );

    let (at, what, _) = scene_err(load_with("mtllib t.mtl\nv 0 0 0\n", MTL));
    assert_eq!(
        at,
        SourceLocation {
            file: "t.obj".into(),
            line: 0
        }
    );
    assert!(what.contains("no faces"));
}

#[test]
fn camera_comment() {
    let obj = "# vkrad camera eye 1 2 3 look_at 0 0 0 up 0 1 0 fov 50\nmtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let s = load_obj(obj).unwrap();
    let c = s.camera.unwrap();
    assert_eq!(c.eye, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(c.look_at, Vec3::ZERO);
    assert_eq!(c.up, Vec3::Y);
    assert_eq!(c.fov_y_deg, 50.0);

    let body = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    // No camera comment: none. Ordinary comments are ignored.
    assert!(load_obj(&format!("# vkrad scene\n{body}"))
        .unwrap()
        .camera
        .is_none());
    for bad in [
        "# vkrad camera eye 1 2 look_at 0 0 0 up 0 1 0 fov 50",
        "# vkrad camera eye 1 2 3 look_at 0 0 0 up 0 1 0",
        "# vkrad camera eye 1 2 3 look_at 0 0 0 up 0 1 0 fov 200",
        "# vkrad camera eye 1 2 3 look_at 1 2 3 up 0 1 0 fov 50",
        "# vkrad camera eye 0 0 1 look_at 0 0 0 up 0 0 1 fov 50",
        "# vkrad camera eye 1 2 3 look_at 0 0 0 up 0 1 0 fov nan",
        "# vkrad camera eye 1 2 3 look_at 0 0 0 up 0 1 0 fov 50 zoom 2",
    ] {
        let (at, what, hint) = scene_err(load_obj(&format!("{body}\n{bad}\n")));
        assert_eq!(at.line, 8, "{bad}: {what}");
        assert!(hint.unwrap().contains("# vkrad camera eye"));
    }
}

#[test]
fn error_message_reads_well() {
    let obj = "mtllib t.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    let msg = load_obj(obj).unwrap_err().to_string();
    assert!(msg.starts_with(
        "t.obj:6: vertex index 4 is out of range: 3 vertices are defined above this line\n  hint: "
    ));
}

/// A public scene under `../shared/scenes`, or `None` (with a note) where
/// this checkout has none.
fn public_scene(rel: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes")
        .join(rel);
    if path.is_file() {
        Some(path)
    } else {
        println!("skipped: {} is not here", path.display());
        None
    }
}

#[test]
fn mcguire_cornell_box_loads_with_its_two_copies_dropped() {
    let Some(path) = public_scene("mcguire/CornellBox-Original.obj") else {
        return;
    };
    let s = load(&path).unwrap();
    for w in &s.warnings {
        println!("warning   {w}");
    }
    // Each box's bottom face is written as a copy of one of its sides.
    let w = warning(&s, "dropped 2 faces that coincide with another face (");
    assert!(
        w.contains("CornellBox-Original.obj:107 (copy of :93), :155 (copy of :148))"),
        "{w}"
    );
    // 18 faces, 2 copies dropped; one non-planar wall split in two.
    assert_eq!(s.patches.len(), 18 - 2 + 1);
    assert!(warning(&s, "split 1 non-planar quad into 2 triangles (").contains("Original.obj:62;"));
    assert_eq!(s.warnings.len(), 3, "{:?}", s.warnings);
    // The stray `v .1 0 0` in the MTL is a warning, not an error.
    assert!(warning(&s, "ignored 1 unknown statement (").contains("`v`"));
    // No material there is specular; the light emits.
    assert!(
        !s.warnings.iter().any(|w| w.contains("\" is ")),
        "{:?}",
        s.warnings
    );
    assert_eq!(
        s.patches
            .iter()
            .filter(|p| s.material_of(p).is_emitter())
            .count(),
        1
    );
}

#[test]
fn mcguire_sphere_box_warns_about_its_mirror_and_glass() {
    let Some(path) = public_scene("mcguire/CornellBox-Sphere.obj") else {
        return;
    };
    let s = load(&path).unwrap();
    for w in &s.warnings {
        println!("warning   {w}");
    }
    let about = |needle: &str| -> Vec<&String> {
        s.warnings.iter().filter(|w| w.contains(needle)).collect()
    };
    let mirror = about("CornellBox-Sphere.mtl:15: material \"leftSphere\" is a mirror (illum 5");
    assert_eq!(mirror.len(), 1, "{:?}", s.warnings);
    assert!(mirror[0].contains("treats it as opaque and diffuse with its Kd 0.01"));
    let glass = about("CornellBox-Sphere.mtl:23: material \"rightSphere\" is transparent (illum 7");
    assert_eq!(glass.len(), 1, "{:?}", s.warnings);
    // Its two stray `v` lines, and nothing about its 2,188 faces.
    assert!(about("ignored 2 unknown statements (")[0].contains(":21 `v`, :31 `v`"));
    assert_eq!(s.warnings.len(), 3, "{:?}", s.warnings);
    // The light's `Tf 1 1 1` with `d 1` is opaque: no warning for it.
    assert!(
        !s.warnings.iter().any(|w| w.contains("\"light\" is")),
        "{:?}",
        s.warnings
    );
}
