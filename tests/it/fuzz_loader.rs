//! Property tests ("fuzzing") of the OBJ/MTL loader through
//! `vkrad::scene::load_from_str`.
//!
//! cargo-fuzz needs a nightly toolchain, which this project's machines do
//! not have, so `proptest` is the fuzzer here. Each property runs 2000 cases
//! by default (a few seconds); run it longer with e.g.
//!
//! ```sh
//! PROPTEST_CASES=100000 cargo test --release --test it fuzz_loader::
//! ```
//!
//! Properties: the loader never panics; every error is an `Error::Scene`
//! that names the OBJ file or an MTL file its `mtllib` names; errors about a
//! statement carry a line number within that file's line count; and a scene
//! that loads satisfies the `Scene` invariants (finite geometry, positive
//! area, unit normals, valid material indices, an emitter).
//!
//! Every failure found is kept below as a named regression test with its
//! explicit input.

use proptest::prelude::*;
use vkrad::error::Error;
use vkrad::scene::{load_from_str, Scene};

const CORNELL_OBJ: &str = include_str!("../../scenes/cornell.obj");
const CORNELL_MTL: &str = include_str!("../../scenes/cornell.mtl");

/// Cases per property: 2000, or `PROPTEST_CASES`.
fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000);
    let default = ProptestConfig::default();
    ProptestConfig {
        cases,
        // Failures are kept as named tests below, not in a side file.
        failure_persistence: None,
        // Deterministic in CI; PROPTEST_RNG_SEED=<n> explores other seeds.
        rng_seed: if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
            default.rng_seed
        } else {
            proptest::test_runner::RngSeed::Fixed(0x5eed_0002)
        },
        ..default
    }
}

/// Lines as the loader counts them: `\n`, `\r\n` or a lone `\r` ends a line.
fn line_count(text: &str) -> usize {
    let mut n = 0;
    let mut rest = text;
    while !rest.is_empty() {
        n += 1;
        match rest.find(['\n', '\r']) {
            Some(i) => {
                let skip = if rest[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = &rest[i + skip..];
            }
            None => break,
        }
    }
    n
}

/// Whole-scene errors, which name the file but no line.
const WHOLE_FILE: &[&str] = &["empty", "no faces", "no emitter", "emitted power"];

/// Loads `obj` as `scene.obj` with `mtl` as the text of every MTL file named
/// `scene.mtl` or `cornell.mtl` (others do not exist), and checks the
/// properties. Returns the scene or the error message.
fn load_and_check(obj: &str, mtl: &str) -> Result<Scene, String> {
    let result = load_from_str("scene.obj", obj, |name| {
        (name == "scene.mtl" || name == "cornell.mtl").then(|| mtl.to_owned())
    });
    match result {
        Ok(scene) => {
            check_scene(&scene);
            Ok(scene)
        }
        Err(Error::Scene { at, what, hint }) => {
            let message = format!("{at}: {what}");
            let file = at.file.to_string_lossy().into_owned();
            let lines = if file == "scene.obj" {
                line_count(obj)
            } else {
                assert!(
                    obj.contains(&format!("mtllib {file}")) || obj.contains(&file),
                    "error names a file the OBJ does not: {message}"
                );
                line_count(mtl)
            };
            if at.line == 0 {
                assert!(
                    WHOLE_FILE.iter().any(|w| what.contains(w))
                        || what.contains("not found")
                        || what.contains("material library"),
                    "a statement error without a line: {message}"
                );
            } else {
                assert!(
                    at.line <= lines.max(1),
                    "line {} beyond the file's {lines} lines: {message}",
                    at.line
                );
            }
            assert!(!what.is_empty(), "empty message at {at}");
            assert!(
                !what.contains("internal error"),
                "internal error: {message}"
            );
            let shown = Error::Scene {
                at: at.clone(),
                what: what.clone(),
                hint: hint.clone(),
            }
            .to_string();
            assert!(shown.starts_with(&file), "{shown}");
            Err(message)
        }
        Err(other) => panic!("not a scene error: {other}"),
    }
}

fn check_scene(s: &Scene) {
    assert!(!s.patches.is_empty());
    assert!(s.patches.iter().any(|p| s.material_of(p).is_emitter()));
    assert!(s.emitted_power().is_finite());
    assert!(s.total_area().is_finite());
    for p in &s.patches {
        assert!(p.material < s.materials.len());
        assert!(p.vertices.len() >= 3, "{p:?}");
        assert!(p.vertices.iter().all(|v| v.is_finite()), "{p:?}");
        assert!(p.area.is_finite() && p.area > 0.0, "{p:?}");
        assert!((p.normal.length() - 1.0).abs() < 1e-4, "{p:?}");
    }
    for m in &s.materials {
        assert!(m.reflectance.is_finite());
        assert!(m.reflectance.min_element() >= 0.0 && m.reflectance.max_element() <= 1.0);
        assert!(m.emission.is_finite() && m.emission.min_element() >= 0.0);
    }
}

// ---- strategies ------------------------------------------------------------

/// Odd numbers: specials, huge, tiny, negative, malformed.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        (-3i64..12).prop_map(|i| i.to_string()),
        any::<f64>().prop_map(|x| x.to_string()),
        (-1e3f64..1e3).prop_map(|x| format!("{x}")),
        prop::sample::select(vec![
            "nan",
            "NaN",
            "inf",
            "-inf",
            "infinity",
            "1e30",
            "-1e30",
            "1e400",
            "1e-400",
            "1e38",
            "3.5e38",
            "-0",
            "0",
            "1e-30",
            "0x10",
            "1.",
            ".5",
            "-",
            "+1",
            "1e",
            "",
            "99999999999999999999",
            "-9223372036854775808",
            "18446744073709551616",
        ])
        .prop_map(str::to_owned),
    ]
}

/// Face references: indices with slashes.
fn reference() -> impl Strategy<Value = String> {
    prop_oneof![
        (-6i64..10).prop_map(|i| i.to_string()),
        ((-6i64..10), (0i64..4)).prop_map(|(a, b)| format!("{a}/{b}")),
        ((-6i64..10), (0i64..4), (0i64..4)).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
        (-6i64..10).prop_map(|a| format!("{a}//1")),
        prop::sample::select(vec!["/", "//", "/1", "1/", "a", "0"]).prop_map(str::to_owned),
    ]
}

fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => prop::sample::select(vec![
            "v", "f", "usemtl", "mtllib", "o", "g", "#", "vt", "vn", "s", "l",
            "white", "light", "scene.mtl", "\n", "\n", "\n", "\t", "\r\n", "\r",
            "# vkrad camera", "eye", "look_at", "up", "fov", "\u{feff}", "\0", "é",
        ])
        .prop_map(str::to_owned),
        3 => number(),
        3 => reference(),
    ]
}

/// A line in OBJ shape, with odd values.
fn obj_line() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::collection::vec(number(), 0..6).prop_map(|n| format!("v {}", n.join(" "))),
        prop::collection::vec(reference(), 0..7).prop_map(|r| format!("f {}", r.join(" "))),
        prop::sample::select(vec!["white", "light", "", "nosuch", "red green"])
            .prop_map(|m| format!("usemtl {m}")),
        prop::sample::select(vec!["scene.mtl", "", "other.mtl", "scene.mtl scene.mtl"])
            .prop_map(|m| format!("mtllib {m}")),
        prop::collection::vec(token(), 0..12).prop_map(|t| t.join(" ")),
    ]
}

/// A line in MTL shape, with odd values.
fn mtl_line() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec!["white", "light", "", "red", "a b"])
            .prop_map(|m| format!("newmtl {m}")),
        (
            prop::sample::select(vec!["Kd", "Ke", "Ka", "Ks", "Ns", "illum", "map_Kd"]),
            prop::collection::vec(number(), 0..5)
        )
            .prop_map(|(k, n)| format!("{k} {}", n.join(" "))),
        prop::collection::vec(token(), 0..8).prop_map(|t| t.join(" ")),
    ]
}

#[derive(Debug, Clone)]
enum Mutation {
    Delete(usize),
    Duplicate(usize),
    Swap(usize, usize),
    /// Replace the k-th word of a line.
    Corrupt(usize, usize, String),
    Insert(usize, String),
}

fn mutation(line: BoxedStrategy<String>) -> impl Strategy<Value = Mutation> {
    prop_oneof![
        1 => any::<usize>().prop_map(Mutation::Delete),
        1 => any::<usize>().prop_map(Mutation::Duplicate),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::Swap(a, b)),
        3 => (any::<usize>(), 0usize..8, number()).prop_map(|(l, w, n)| Mutation::Corrupt(l, w, n)),
        1 => (any::<usize>(), line).prop_map(|(l, s)| Mutation::Insert(l, s)),
    ]
}

fn mutate(text: &str, mutations: &[Mutation]) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    for m in mutations {
        if lines.is_empty() {
            break;
        }
        let n = lines.len();
        match m {
            Mutation::Delete(i) => {
                lines.remove(i % n);
            }
            Mutation::Duplicate(i) => {
                let l = lines[i % n].clone();
                lines.insert(i % n, l);
            }
            Mutation::Swap(a, b) => lines.swap(a % n, b % n),
            Mutation::Corrupt(i, w, word) => {
                let mut words: Vec<String> =
                    lines[i % n].split_whitespace().map(str::to_owned).collect();
                if words.is_empty() {
                    words.push(word.clone());
                } else {
                    let k = w % words.len();
                    words[k] = word.clone();
                }
                lines[i % n] = words.join(" ");
            }
            Mutation::Insert(i, l) => lines.insert(i % (n + 1), l.clone()),
        }
    }
    lines.join("\n") + "\n"
}

/// The Cornell OBJ with only the light, so mutations hit the light often.
fn cornell() -> String {
    CORNELL_OBJ.to_owned()
}

proptest! {
    #![proptest_config(config())]

    /// Random token soup built from OBJ keywords, numbers and slashes.
    #[test]
    fn token_soup_never_panics(tokens in prop::collection::vec(token(), 0..80),
                               mtl in prop::collection::vec(mtl_line(), 0..8)) {
        let obj = tokens.join(" ");
        let _ = load_and_check(&obj, &(mtl.join("\n") + "\n"));
    }

    /// Random lines in OBJ shape (more of them get past the first checks).
    #[test]
    fn obj_shaped_lines_never_panic(lines in prop::collection::vec(obj_line(), 0..40)) {
        let obj = format!("mtllib scene.mtl\n{}\n", lines.join("\n"));
        let _ = load_and_check(&obj, CORNELL_MTL);
    }

    /// The Cornell box with lines deleted, duplicated, swapped, corrupted or
    /// inserted.
    #[test]
    fn mutated_cornell_never_panics(
        m in prop::collection::vec(mutation(obj_line().boxed()), 1..6)
    ) {
        let obj = mutate(&cornell(), &m);
        let _ = load_and_check(&obj, CORNELL_MTL);
    }

    /// The Cornell MTL mutated (the OBJ intact).
    #[test]
    fn mutated_cornell_mtl_never_panics(
        m in prop::collection::vec(mutation(mtl_line().boxed()), 1..6)
    ) {
        let mtl = mutate(CORNELL_MTL, &m);
        let _ = load_and_check(CORNELL_OBJ, &mtl);
    }

    /// Geometry-level fuzz: random small polygons from a few points with
    /// random exact coordinates (duplicates, collinear, non-planar, concave,
    /// self-intersecting), appended to the Cornell box.
    #[test]
    fn random_polygons_never_panic(
        points in prop::collection::vec((-2i32..3, -2i32..3, -2i32..3), 1..9),
        faces in prop::collection::vec(prop::collection::vec(-9i64..0, 3..9), 1..4),
        scale in prop::sample::select(vec![1.0f64, 1e-20, 1e-5, 1e5, 1e14, 1e20]),
        offset in prop::sample::select(vec![0.0f64, 1e6, 1e9]),
    ) {
        let mut obj = cornell();
        obj += "usemtl white\n";
        for (x, y, z) in &points {
            obj += &format!(
                "v {} {} {}\n",
                *x as f64 * scale + offset,
                *y as f64 * scale,
                *z as f64 * scale
            );
        }
        for f in &faces {
            let refs: Vec<String> = f.iter().map(|i| i.to_string()).collect();
            obj += &format!("f {}\n", refs.join(" "));
        }
        let _ = load_and_check(&obj, CORNELL_MTL);
    }
}

// ---- textures ---------------------------------------------------------------

/// Small valid images in every format the loader reads, 5 x 3 texels.
fn seed_images() -> Vec<(&'static str, Vec<u8>)> {
    let img = image::RgbImage::from_fn(5, 3, |x, y| image::Rgb([x as u8 * 50, y as u8 * 80, 7]));
    let mut out = Vec::new();
    for (ext, format) in [
        ("png", image::ImageFormat::Png),
        ("jpg", image::ImageFormat::Jpeg),
        ("bmp", image::ImageFormat::Bmp),
        ("tga", image::ImageFormat::Tga),
    ] {
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, format).expect("encodes");
        out.push((ext, bytes.into_inner()));
    }
    let rgb32f = image::DynamicImage::ImageRgb8(img).into_rgb32f();
    let mut hdr = std::io::Cursor::new(Vec::new());
    rgb32f
        .write_to(&mut hdr, image::ImageFormat::Hdr)
        .expect("encodes");
    out.push(("hdr", hdr.into_inner()));
    out
}

/// A change to an image file's bytes.
#[derive(Debug, Clone)]
enum ByteEdit {
    /// Flip bits of the byte at (index mod length).
    Flip(usize, u8),
    /// Write a 32-bit value (little or big endian) at (index mod length),
    /// e.g. over a width, a height or a chunk length.
    Word(usize, u32, bool),
    /// Cut the file at (index mod length).
    Truncate(usize),
    /// Insert bytes at (index mod length).
    Insert(usize, Vec<u8>),
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    let extreme = prop::sample::select(vec![
        0u32,
        1,
        0x7fff,
        0xffff,
        0x10000,
        0x7fff_ffff,
        u32::MAX,
    ]);
    prop_oneof![
        4 => (any::<usize>(), 1u8..=255).prop_map(|(i, b)| ByteEdit::Flip(i, b)),
        3 => (any::<usize>(), prop_oneof![extreme, any::<u32>()], any::<bool>())
            .prop_map(|(i, w, le)| ByteEdit::Word(i, w, le)),
        1 => any::<usize>().prop_map(ByteEdit::Truncate),
        1 => (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, b)| ByteEdit::Insert(i, b)),
    ]
}

fn edit_bytes(mut bytes: Vec<u8>, edits: &[ByteEdit]) -> Vec<u8> {
    for e in edits {
        let n = bytes.len().max(1);
        match e {
            ByteEdit::Flip(i, b) => {
                if let Some(x) = bytes.get_mut(i % n) {
                    *x ^= b;
                }
            }
            ByteEdit::Word(i, w, le) => {
                let at = i % n;
                let word = if *le {
                    w.to_le_bytes()
                } else {
                    w.to_be_bytes()
                };
                for (k, b) in word.into_iter().enumerate() {
                    if let Some(x) = bytes.get_mut(at + k) {
                        *x = b;
                    }
                }
            }
            ByteEdit::Truncate(i) => bytes.truncate(i % n),
            ByteEdit::Insert(i, more) => {
                let at = (i % n).min(bytes.len());
                bytes.splice(at..at, more.iter().copied());
            }
        }
    }
    bytes
}

/// A folder for the texture cases, one per test thread.
fn texture_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vkrad-fuzz-textures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

proptest! {
    #![proptest_config(config())]

    /// Damaged image files through `Texture::load`, then through a whole
    /// scene whose material names them: never a panic; a texture that
    /// loads has texels; one that does not is a warning naming the file,
    /// and the scene still loads with `Kd` alone.
    #[test]
    fn damaged_textures_never_panic(
        which in 0usize..5,
        edits in prop::collection::vec(byte_edit(), 1..5),
    ) {
        let (ext, bytes) = seed_images().swap_remove(which);
        let bytes = edit_bytes(bytes, &edits);
        let dir = texture_dir();
        let file = dir.join(format!("t.{ext}"));
        std::fs::write(&file, &bytes).unwrap();
        if let Ok(t) = vkrad::scene::Texture::load(file.clone()) {
            prop_assert!(t.sample(glam::Vec2::new(0.3, 0.6)).is_finite());
        }
        let obj = dir.join("scene.obj");
        std::fs::write(
            &obj,
            "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl tex\nf 1/1 4/4 3/3 2/2\nv 0 1 0\nv 0 1 1\nv 1 1 1\nv 1 1 0\nusemtl light\nf 5 8 7 6\n",
        )
        .unwrap();
        std::fs::write(dir.join("scene.mtl"), format!(
            "newmtl tex\nKd 0.5 0.5 0.5\nmap_Kd t.{ext}\nnewmtl light\nKd 0 0 0\nKe 1 1 1\n"
        )).unwrap();
        match vkrad::scene::load(&obj) {
            Ok(scene) => {
                check_scene(&scene);
                if scene.textures.is_empty() {
                    prop_assert!(
                        scene.warnings.iter().any(|w| w.contains("cannot read texture") && w.contains(&format!("t.{ext}"))),
                        "{:?}", scene.warnings
                    );
                }
            }
            Err(e) => prop_assert!(false, "a bad texture must not fail the scene: {e}"),
        }
    }
}

// ---- regressions: failures found by the properties above ------------------

/// The unmodified built-ins pass the same checks.
#[test]
fn cornell_passes_the_checks() {
    load_and_check(CORNELL_OBJ, CORNELL_MTL).unwrap();
}

/// Found by `random_polygons_never_panic`: a face of size 1e20 loaded with
/// area 5e39, infinite in f32, so `Scene::emitted_power` was NaN (0 x inf).
/// Now coordinates beyond 1e9 are an error on their `v` line.
#[test]
fn regression_huge_face_area_overflowed_f32() {
    let obj = format!(
        "{CORNELL_OBJ}usemtl white\nv 0 0 1e20\nv 0 0 0\nv 0 0 0\nv 1e20 0 0\nf -4 -1 -2\n"
    );
    let err = load_and_check(&obj, CORNELL_MTL).unwrap_err();
    let line = CORNELL_OBJ.lines().count() + 2;
    assert!(
        err.starts_with(&format!("scene.obj:{line}: coordinate 1e20 is too large")),
        "{err}"
    );
}

/// Found by `mutated_cornell_mtl_never_panics`: `Ke 17 1.87e36 4` passed
/// validation but pi x Ke x area overflowed f32 (the renderer then panicked
/// in the solver's heap: "heap keys must be finite").
#[test]
fn regression_huge_ke_overflowed_emitted_power() {
    let mtl = CORNELL_MTL.replace(
        "Ke 17 12 4",
        "Ke 17 1866724455322224700000000000000000000 4",
    );
    let err = load_and_check(CORNELL_OBJ, &mtl).unwrap_err();
    assert!(
        err.starts_with("cornell.mtl:13: material \"light\": emitted power"),
        "{err}"
    );
}
