//! A corpus of bad scenes, generated here (no fixture files), each run
//! through the `vkrad` binary in its own temp folder:
//!
//! `vkrad scene.obj -o out.png --size 32x32 --tune hemicube_res=16 --tune max_shots=200`
//!
//! Every case ends in exactly one documented way:
//! - a clear error: non-zero exit, the message names `scene.obj:LINE` (or the
//!   MTL file, or the file as a whole for whole-scene problems), carries a
//!   `hint:` where the user has something to do, and the folder holds only
//!   the inputs afterwards;
//! - a documented repair: exit 0, a `warning` line in stdout saying what was
//!   done (one line per kind of repair, with a count and the first few
//!   `scene.obj:LINE`), and a whole 32x32 PNG;
//! - or it simply works.
//!
//! Never `panicked` in stderr, never a partial or temporary file, and each run
//! is killed (and fails) after 60 s.
//!
//! The million-face scene is only loaded in-process (`vkrad::scene::load`),
//! not rendered: lavapipe would take far too long.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const MTL: &str = "newmtl white\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0.5 0.5 0.5\nKe 5 5 5\n";

/// A unit box's floor (facing up, line 11) and a light above it (facing
/// down, line 13). Lines: 1 mtllib, 2-5 floor vertices, 6-9 light vertices,
/// 10 usemtl white, 11 floor face, 12 usemtl light, 13 light face.
const GOOD_OBJ: &str = "mtllib scene.mtl\n\
v 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\n\
v 0 1 0\nv 1 1 0\nv 1 1 1\nv 0 1 1\n\
usemtl white\nf 1 2 3 4\nusemtl light\nf 5 6 7 8\n";

/// Line number of the first line appended to `GOOD_OBJ`.
const APPENDED: usize = 14;

/// What a case must do.
#[derive(Debug, Clone)]
enum Expect {
    /// Non-zero exit; stderr contains every needle; `hint` says whether a
    /// `hint:` line is required.
    Error { needles: Vec<String>, hint: bool },
    /// Exit 0, a `warning` line in stdout containing every needle.
    Repair { needles: Vec<String> },
    /// Exit 0; stdout contains every needle (may be none).
    Works { needles: Vec<String> },
}

#[derive(Debug, Clone)]
struct Case {
    name: String,
    obj: Vec<u8>,
    /// `scene.mtl`, when present.
    mtl: Option<Vec<u8>>,
    expect: Expect,
}

fn strings(needles: &[&str]) -> Vec<String> {
    needles.iter().map(|s| s.to_string()).collect()
}

fn error(needles: &[&str]) -> Expect {
    Expect::Error {
        needles: strings(needles),
        hint: true,
    }
}

fn repair(needles: &[&str]) -> Expect {
    Expect::Repair {
        needles: strings(needles),
    }
}

fn works(needles: &[&str]) -> Expect {
    Expect::Works {
        needles: strings(needles),
    }
}

fn at(line: usize) -> String {
    format!("scene.obj:{line}")
}

// ---- generators ------------------------------------------------------------

/// A case from OBJ text and the standard MTL.
fn obj_case(name: &str, obj: impl Into<String>, expect: Expect) -> Case {
    Case {
        name: name.into(),
        obj: obj.into().into_bytes(),
        mtl: Some(MTL.as_bytes().to_vec()),
        expect,
    }
}

/// `GOOD_OBJ` with one line (1-based) replaced by `new`.
fn replace_line(line: usize, new: &str) -> String {
    let mut lines: Vec<&str> = GOOD_OBJ.lines().collect();
    lines[line - 1] = new;
    lines.join("\n") + "\n"
}

/// `GOOD_OBJ` followed by `extra` (the first extra line is `APPENDED`).
fn append(extra: &str) -> String {
    format!("{GOOD_OBJ}{extra}")
}

/// `GOOD_OBJ` with a white face on the given vertices appended (vertices
/// first, then `usemtl white` and the face with relative indices). The face
/// line is `APPENDED + vertices.len() + 1`.
fn append_face(vertices: &[[f64; 3]]) -> (String, usize) {
    let mut s = String::new();
    for v in vertices {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    s += "usemtl white\nf";
    for k in (1..=vertices.len()).rev() {
        s += &format!(" -{k}");
    }
    s += "\n";
    (append(&s), APPENDED + vertices.len() + 1)
}

/// `GOOD_OBJ` with every coordinate mapped by `f`.
fn transform(f: impl Fn(f64) -> f64) -> String {
    GOOD_OBJ
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let c: Vec<String> = rest
                    .split_whitespace()
                    .map(|x| format!("{:e}", f(x.parse::<f64>().unwrap())))
                    .collect();
                format!("v {}\n", c.join(" "))
            }
            None => format!("{l}\n"),
        })
        .collect()
}

/// `GOOD_OBJ` with the standard MTL where material `which` gets `line`
/// instead of its `Kd`/`Ke` statement of the same keyword (or the extra
/// line appended to it). Returns the MTL and the line of the change.
fn mtl_with(which: &str, keyword: &str, values: &str) -> (String, usize) {
    let mut lines: Vec<String> = MTL.lines().map(str::to_owned).collect();
    let start = lines
        .iter()
        .position(|l| l == &format!("newmtl {which}"))
        .unwrap();
    let mut end = start + 1;
    while end < lines.len() && !lines[end].starts_with("newmtl") {
        end += 1;
    }
    let new = format!("{keyword} {values}");
    let line = match (start + 1..end).find(|&i| lines[i].starts_with(keyword)) {
        Some(i) => {
            lines[i] = new;
            i
        }
        None => {
            lines.insert(end, new);
            end
        }
    };
    (lines.join("\n") + "\n", line + 1)
}

fn mtl_case(name: &str, which: &str, keyword: &str, values: &str, what: &str) -> Case {
    let (mtl, line) = mtl_with(which, keyword, values);
    Case {
        name: name.into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some(mtl.into_bytes()),
        expect: error(&[&format!("scene.mtl:{line}"), what]),
    }
}

/// Deterministic pseudo-random bytes (xorshift), so a failure reproduces.
fn garbage(seed: u64, len: usize) -> Vec<u8> {
    let mut x = seed | 1;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 32) as u8
        })
        .collect()
}

/// The 1-based line of the first byte that is not valid UTF-8.
fn first_bad_utf8_line(bytes: &[u8]) -> usize {
    let valid = std::str::from_utf8(bytes).map_or_else(|e| e.valid_up_to(), |s| s.len());
    1 + bytes[..valid].iter().filter(|&&b| b == b'\n').count()
}

/// A closed unit cube, every face facing in: `Kd` of the walls as given,
/// one small light under the ceiling.
fn closed_room(kd: &str) -> Case {
    let obj = "mtllib scene.mtl\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
usemtl white\n\
f 1 5 6 2\nf 4 3 7 8\nf 1 4 8 5\nf 2 6 7 3\nf 1 2 3 4\nf 5 8 7 6\n\
v 0.4 0.99 0.4\nv 0.6 0.99 0.4\nv 0.6 0.99 0.6\nv 0.4 0.99 0.6\n\
usemtl light\nf -4 -3 -2 -1\n";
    Case {
        name: "closed room with reflectance 1 (no convergence)".into(),
        obj: obj.as_bytes().to_vec(),
        mtl: Some(format!("newmtl white\nKd {kd}\nnewmtl light\nKd 0\nKe 5 5 5\n").into_bytes()),
        expect: works(&["200 shots", "NOT converged"]),
    }
}

/// A regular n-gon in the plane y = 0.5, facing up.
fn ngon(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let a = -(k as f64) * std::f64::consts::TAU / n as f64;
            [0.5 + 0.4 * a.cos(), 0.5, 0.5 + 0.4 * a.sin()]
        })
        .collect()
}

/// The whole table.
fn cases() -> Vec<Case> {
    let mut c = Vec::new();

    // Empty and not-text input.
    c.push(obj_case("empty file", "", error(&["scene.obj", "empty"])));
    c.push(obj_case(
        "only comments and blank lines",
        "# a scene\n\n   \n# nothing here\n",
        error(&["scene.obj", "no faces"]),
    ));
    for seed in [1u64, 2, 3] {
        let mut bytes = garbage(seed, 4096);
        bytes[100] = 0;
        bytes[200] = 0xff; // never valid UTF-8
        let line = first_bad_utf8_line(&bytes);
        c.push(Case {
            name: format!("binary garbage (seed {seed})"),
            obj: bytes,
            mtl: None,
            expect: error(&[&at(line), "UTF-8"]),
        });
    }
    c.push(obj_case(
        "NUL byte inside a vertex line",
        replace_line(3, "v 0 0\0 1"),
        error(&[&at(3), "not a number"]),
    ));
    c.push(obj_case(
        "old Mac line endings (CR only)",
        GOOD_OBJ.replace('\n', "\r"),
        works(&["2 patches"]),
    ));
    c.push(obj_case(
        "Windows line endings (CRLF)",
        GOOD_OBJ.replace('\n', "\r\n"),
        works(&["2 patches"]),
    ));

    // Truncated statements.
    c.push(obj_case(
        "truncated vertex `v 1 2`",
        replace_line(4, "v 1 2"),
        error(&[&at(4), "needs 3 coordinates"]),
    ));
    c.push(obj_case(
        "vertex with 5 numbers",
        replace_line(4, "v 1 0 1 1 7"),
        error(&[&at(4), "5 numbers"]),
    ));
    c.push(obj_case(
        "truncated face `f 1`",
        replace_line(11, "f 1"),
        error(&[&at(11), "at least 3 vertices, this one has 1"]),
    ));
    c.push(obj_case(
        "face with 2 vertices",
        replace_line(11, "f 1 2"),
        error(&[&at(11), "at least 3 vertices, this one has 2"]),
    ));
    c.push(obj_case(
        "face without indices",
        replace_line(11, "f"),
        error(&[&at(11), "this one has 0"]),
    ));

    // Indices.
    c.push(obj_case(
        "index out of range",
        replace_line(13, "f 5 6 7 99"),
        error(&[&at(13), "vertex index 99 is out of range"]),
    ));
    c.push(obj_case(
        "index refers to a vertex defined later",
        format!("mtllib scene.mtl\nusemtl white\nf 1 2 3\n{GOOD_OBJ}"),
        error(&[&at(3), "out of range: 0 vertices"]),
    ));
    c.push(obj_case(
        "index zero",
        replace_line(11, "f 0 1 2"),
        error(&[&at(11), "index 0 is invalid"]),
    ));
    c.push(obj_case(
        "negative index out of range",
        replace_line(13, "f -1 -2 -99"),
        error(&[&at(13), "vertex index -99 is out of range"]),
    ));
    c.push(obj_case(
        "index beyond i64",
        replace_line(13, "f 5 6 99999999999999999999999"),
        error(&[&at(13), "not a vertex index"]),
    ));
    c.push(obj_case(
        "negative (relative) indices in range",
        replace_line(13, "f -4 -3 -2 -1"),
        works(&["2 patches"]),
    ));
    c.push(obj_case(
        "v/vt/vn references",
        replace_line(13, "f 5/1/1 6/2/1 7//1 8/3"),
        works(&["2 patches"]),
    ));

    // Non-finite and extreme coordinates.
    for (name, word) in [
        ("NaN coordinate", "nan"),
        ("infinite coordinate", "inf"),
        ("-infinity coordinate", "-infinity"),
        ("coordinate overflowing to infinity (1e400)", "1e400"),
    ] {
        c.push(obj_case(
            name,
            replace_line(6, &format!("v {word} 1 0")),
            error(&[&at(6), "not a finite number"]),
        ));
    }
    c.push(obj_case(
        "huge coordinate (1e30)",
        replace_line(6, "v 1e30 1 0"),
        error(&[&at(6), "too large"]),
    ));
    c.push(obj_case(
        "huge weight division (w = 1e-300)",
        replace_line(6, "v 1 1 1 1e-300"),
        error(&[&at(6), "too large"]),
    ));
    c.push(obj_case(
        "whole scene scaled to 1e30",
        transform(|x| x * 1e30),
        error(&[&at(3), "too large"]),
    ));
    c.push(obj_case(
        "whole scene scaled to 1e12 (beyond the 1e9 coordinate limit)",
        transform(|x| x * 1e12),
        error(&[&at(3), "too large"]),
    ));
    c.push(obj_case(
        "whole scene scaled to 1e8 (large but representable)",
        transform(|x| x * 1e8),
        works(&["2 patches"]),
    ));
    c.push(obj_case(
        "whole scene scaled to 1e-30 (area underflows single precision)",
        transform(|x| x * 1e-30),
        error(&[&at(11), "single precision"]),
    ));
    c.push(obj_case(
        "scene far from the origin (1e8 offset, unit faces)",
        transform(|x| x + 1e8),
        error(&[&at(11), "single precision"]),
    ));

    // Degenerate faces: dropped, counted in one warning line.
    c.push(obj_case(
        "zero-area face (one index repeated)",
        replace_line(11, "f 1 1 1"),
        repair(&[&format!("dropped 1 zero-area face ({})", at(11))]),
    ));
    let (obj, line) = append_face(&[[0., 0.5, 0.], [0.5, 0.5, 0.], [1., 0.5, 0.]]);
    c.push(obj_case(
        "collinear triangle",
        obj,
        repair(&[&format!("dropped 1 zero-area face ({})", at(line))]),
    ));
    let (obj, line) = append_face(&[[0., 0.5, 0.], [0.3, 0.5, 0.], [0.6, 0.5, 0.], [1., 0.5, 0.]]);
    c.push(obj_case(
        "collinear quad",
        obj,
        repair(&[&format!("dropped 1 zero-area face ({})", at(line))]),
    ));
    c.push(obj_case(
        "many zero-area faces: one line, a count and the first three",
        append("usemtl white\nf 1 1 2\nf 2 2 3\nf 3 3 4\nf 4 4 1\nf 1 2 1\n"),
        repair(&[&format!(
            "dropped 5 zero-area faces ({}, :{}, :{}, ...)",
            at(APPENDED + 1),
            APPENDED + 2,
            APPENDED + 3
        )]),
    ));
    c.push(obj_case(
        "every face zero-area",
        "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nusemtl light\nf 1 2 2\nf 1 1 1\n",
        error(&["scene.obj", "no faces left", "dropped (scene.obj:5, :6)"]),
    ));
    c.push(obj_case(
        "zero-area face with an index out of range (still an error)",
        replace_line(11, "f 1 1 99"),
        error(&[&at(11), "vertex index 99 is out of range"]),
    ));
    c.push(obj_case(
        "the floor written twice (another starting vertex)",
        append("usemtl white\nf 3 4 1 2\n"),
        repair(&[&format!(
            "dropped 1 face that coincides with another face ({} (copy of :11))",
            at(APPENDED + 1)
        )]),
    ));
    c.push(obj_case(
        "the floor and its back (opposite copies: a two-sided wall, kept)",
        append("usemtl white\nf 4 3 2 1\n"),
        works(&["3 patches"]),
    ));
    let (obj, line) = append_face(&[[0., 0.5, 0.], [1., 0.5, 1.], [1., 0.5, 0.], [0., 0.5, 1.]]);
    c.push(obj_case(
        "symmetric bow tie (parts cancel)",
        obj,
        repair(&[
            &at(line),
            "split 1 self-intersecting face into 2 simple pieces",
        ]),
    ));
    let (obj, line) = append_face(&[[0., 0.5, 0.], [1., 0.5, 1.], [1., 0.5, 0.], [0., 0.5, 0.5]]);
    c.push(obj_case(
        "lopsided bow tie (self-intersecting)",
        obj,
        repair(&[
            &at(line),
            "split 1 self-intersecting face into 2 simple pieces",
        ]),
    ));
    let star: Vec<[f64; 3]> = (0..5)
        .map(|k| {
            let a = -((2 * k) as f64) * std::f64::consts::TAU / 5.0;
            [0.5 + 0.4 * a.cos(), 0.5, 0.5 + 0.4 * a.sin()]
        })
        .collect();
    let (obj, line) = append_face(&star);
    c.push(obj_case(
        "pentagram (its parts overlap: no one reading)",
        obj,
        error(&[&at(line), "intersects itself", "overlap"]),
    ));
    c.push(obj_case(
        "line and point elements",
        append("l 1 2 3\np 5\n"),
        repair(&[
            &format!("skipped 1 line element (`l`) ({})", at(APPENDED)),
            &format!("skipped 1 point element (`p`) ({})", at(APPENDED + 1)),
        ]),
    ));

    // Duplicate vertices.
    c.push(obj_case(
        "repeated index in a face",
        replace_line(11, "f 1 2 2 3 4"),
        repair(&[&at(11), "removed 1 repeated vertex"]),
    ));
    c.push(obj_case(
        "face revisits a vertex",
        replace_line(11, "f 1 2 3 2 4"),
        repair(&[
            &at(11),
            "split 1 self-intersecting face into 1 simple piece",
        ]),
    ));
    c.push(obj_case(
        "two `v` lines at one position in a quad (the floor's back)",
        append("v 1 0 1\nusemtl white\nf 4 -1 3 2 1\n"),
        repair(&[&at(APPENDED + 2), "removed 1 repeated vertex"]),
    ));
    c.push(obj_case(
        "two `v` lines at one position in a triangle",
        append("v 0 0 1\nusemtl white\nf 1 2 -1\n"),
        repair(&[&format!("dropped 1 zero-area face ({})", at(APPENDED + 2))]),
    ));

    // Non-planar and concave polygons: split with a warning.
    c.push(obj_case(
        "non-planar quad",
        replace_line(4, "v 1 0.2 1"),
        repair(&[&at(11), "split 1 non-planar quad into 2 triangles"]),
    ));
    let (obj, line) = append_face(&[
        [0.1, 0.5, 0.1],
        [0.1, 0.5, 0.9],
        [0.5, 0.5, 0.9],
        [0.5, 0.5, 0.5],
        [0.9, 0.5, 0.5],
        [0.9, 0.5, 0.1],
    ]);
    c.push(obj_case(
        "concave L-shaped polygon",
        obj,
        repair(&[&at(line), "split 1 concave polygon into 4 triangles"]),
    ));
    let (obj, line) = append_face(&ngon(100_000));
    c.push(obj_case(
        "face with 100000 vertices",
        obj,
        error(&[&at(line), "100000 vertices"]),
    ));

    // Materials.
    c.push(Case {
        name: "missing MTL file".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: None,
        expect: error(&[&at(1), "scene.mtl", "not found"]),
    });
    c.push(obj_case(
        "mtllib names a folder",
        replace_line(1, "mtllib ."),
        error(&[&at(1), "cannot read material library"]),
    ));
    c.push(Case {
        name: "MTL is binary garbage".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some({
            let mut b = garbage(7, 2000);
            b[10] = 0xff;
            b
        }),
        expect: error(&["scene.mtl:1", "UTF-8"]),
    });
    c.push(mtl_case(
        "Kd above 1",
        "white",
        "Kd",
        "0.5 1.2 0.5",
        "outside [0, 1]",
    ));
    c.push(mtl_case(
        "negative Kd",
        "white",
        "Kd",
        "-0.1 0.5 0.5",
        "outside [0, 1]",
    ));
    c.push(mtl_case(
        "NaN Kd",
        "white",
        "Kd",
        "nan 0.5 0.5",
        "outside [0, 1]",
    ));
    c.push(mtl_case("negative Ke", "light", "Ke", "5 -1 5", "negative"));
    c.push(mtl_case(
        "infinite Ke",
        "light",
        "Ke",
        "inf 5 5",
        "not finite",
    ));
    let (mtl, _) = mtl_with("light", "Ke", "3e38 3e38 3e38");
    c.push(Case {
        name: "Ke so large the emitted power overflows".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some(mtl.into_bytes()),
        expect: error(&["scene.mtl:3", "emitted power"]),
    });
    c.push(mtl_case(
        "Kd with two numbers",
        "white",
        "Kd",
        "0.5 0.5",
        "needs 3 numbers",
    ));
    c.push(obj_case(
        "unknown material",
        replace_line(12, "usemtl lamp"),
        error(&[&at(12), "unknown material \"lamp\""]),
    ));
    c.push(Case {
        name: "no emitter (the material named light has no Ke)".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some(MTL.replace("Ke 5 5 5", "").into_bytes()),
        expect: error(&[
            "scene.obj",
            "no emitter",
            "\"light\" (scene.mtl:3: its name) looks like a light",
            "`Ke`",
        ]),
    });
    c.push(Case {
        name: "no emitter, no material that looks like a light".into(),
        obj: GOOD_OBJ
            .replace("usemtl light", "usemtl white")
            .into_bytes(),
        mtl: Some(b"newmtl white\nKd 0.5 0.5 0.5\n".to_vec()),
        expect: error(&["scene.obj", "no emitter: no material has a positive Ke"]),
    });
    c.push(Case {
        name: "stray lines in the MTL file".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some(format!("Kd 1 1 1\n{MTL}  v .1 0 0\nwhat is this\n").into_bytes()),
        expect: repair(&[
            "ignored 1 statement before the first `newmtl` (scene.mtl:1 `Kd`)",
            "ignored 2 unknown statements (scene.mtl:7 `v`, :8 `what`)",
        ]),
    });
    c.push(Case {
        name: "a mirror material".into(),
        obj: GOOD_OBJ.as_bytes().to_vec(),
        mtl: Some(
            MTL.replace(
                "Kd 0.5 0.5 0.5\nnewmtl light",
                "Kd 0.1 0.1 0.1\nKs 0.9 0.9 0.9\nillum 5\nnewmtl light",
            )
            .into_bytes(),
        ),
        expect: repair(&[
            "scene.mtl:1: material \"white\" is a mirror (illum 5, Ks 0.9)",
            "treats it as opaque and diffuse with its Kd 0.1",
        ]),
    });

    // Emitters that light nothing, and a scene that never converges.
    c.push(obj_case(
        "emitter facing away from everything",
        replace_line(13, "f 8 7 6 5"),
        repair(&[&at(13), "faces away from every other face"]),
    ));
    c.push(closed_room("1 1 1"));
    c
}

// ---- running ---------------------------------------------------------------

struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    secs: f64,
}

fn run_vkrad(dir: &Path) -> Run {
    let t = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "scene.obj",
            "-o",
            "out.png",
            "--size",
            "32x32",
            "--tune",
            "hemicube_res=16",
            "--tune",
            "max_shots=200",
        ])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start vkrad");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut s = Vec::new();
        out.read_to_end(&mut s).ok();
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = Vec::new();
        err.read_to_end(&mut s).ok();
        s
    });
    let deadline = Duration::from_secs(60);
    let code = loop {
        if let Some(status) = child.try_wait().expect("wait for vkrad") {
            break status.code();
        }
        if t.elapsed() > deadline {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run {
        code,
        stdout: String::from_utf8_lossy(&out.join().unwrap()).into_owned(),
        stderr: String::from_utf8_lossy(&err.join().unwrap()).into_owned(),
        secs: t.elapsed().as_secs_f64(),
    }
}

fn case_dir(i: usize) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vkrad-bad-{}-{i}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs one case; `Err` says what went wrong.
fn check(i: usize, case: &Case) -> Result<String, String> {
    let dir = case_dir(i);
    std::fs::write(dir.join("scene.obj"), &case.obj).unwrap();
    if let Some(mtl) = &case.mtl {
        std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    }
    let run = run_vkrad(&dir);
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "scene.obj" && n != "scene.mtl")
        .collect();
    files.sort();
    let show = format!(
        "exit {:?} after {:.1}s\n--- stdout\n{}--- stderr\n{}",
        run.code, run.secs, run.stdout, run.stderr
    );
    let fail = |why: String| Err(format!("{why}\n{show}"));
    if run.code.is_none() {
        return fail("killed after 60 s (or by a signal)".into());
    }
    if run.stderr.contains("panicked") {
        return fail("panicked".into());
    }
    let summary = match &case.expect {
        Expect::Error { needles, hint } => {
            if run.code == Some(0) {
                return fail("expected an error, got exit 0".into());
            }
            for n in needles {
                if !run.stderr.contains(n.as_str()) {
                    return fail(format!("the message lacks {n:?}"));
                }
            }
            if *hint && !run.stderr.contains("hint:") {
                return fail("the message has no `hint:`".into());
            }
            if !files.is_empty() {
                return fail(format!("left files behind: {files:?}"));
            }
            let first = run.stderr.lines().next().unwrap_or("");
            format!("error   {first}")
        }
        Expect::Repair { needles } | Expect::Works { needles } => {
            if run.code != Some(0) {
                return fail("expected success".into());
            }
            let text = match &case.expect {
                Expect::Repair { .. } => {
                    let warnings: Vec<&str> = run
                        .stdout
                        .lines()
                        .filter(|l| l.contains("warning"))
                        .collect();
                    if warnings.is_empty() {
                        return fail("no warning in stdout".into());
                    }
                    warnings.join("\n")
                }
                _ => run.stdout.clone(),
            };
            for n in needles {
                if !text.contains(n.as_str()) {
                    return fail(format!("stdout lacks {n:?}"));
                }
            }
            if files != ["out.png"] {
                return fail(format!("expected only out.png, found {files:?}"));
            }
            let png = image::open(dir.join("out.png")).map_err(|e| format!("out.png: {e}"))?;
            if (png.width(), png.height()) != (32, 32) {
                return fail(format!("out.png is {}x{}", png.width(), png.height()));
            }
            match &case.expect {
                Expect::Repair { .. } => format!("repair  {}", text.lines().next().unwrap().trim()),
                _ => "works".to_owned(),
            }
        }
    };
    std::fs::remove_dir_all(&dir).ok();
    Ok(summary)
}

#[test]
fn bad_scenes_fail_clearly_or_are_repaired() {
    let cases = cases();
    let mut failures = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        match check(i, case) {
            Ok(summary) => println!("ok   {:<62} {summary}", case.name),
            Err(why) => {
                println!("FAIL {}", case.name);
                failures.push(format!("== {} ==\n{why}", case.name));
            }
        }
    }
    println!(
        "{} bad-scene cases run through the binary, {} failed (+1 million-face load in bad_scenes::million_faces_load_in_bounded_time_and_memory)",
        cases.len(),
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

// ---- a million faces -------------------------------------------------------

/// Peak resident memory of this process so far (VmHWM), in bytes.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A `n x n` grid of tiny quads in y = 0 (facing up) and one light above it.
pub fn grid_obj(n: usize) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(n * n * 40);
    s += "mtllib scene.mtl\n";
    let step = 1.0 / n as f64;
    for i in 0..=n {
        for j in 0..=n {
            writeln!(s, "v {} 0 {}", i as f64 * step, j as f64 * step).unwrap();
        }
    }
    s += "usemtl white\n";
    let id = |i: usize, j: usize| i * (n + 1) + j + 1;
    for i in 0..n {
        for j in 0..n {
            // (i,j) -> (i,j+1) -> (i+1,j+1) -> (i+1,j): CCW seen from +y.
            writeln!(
                s,
                "f {} {} {} {}",
                id(i, j),
                id(i, j + 1),
                id(i + 1, j + 1),
                id(i + 1, j)
            )
            .unwrap();
        }
    }
    s += "v 0.4 1 0.4\nv 0.6 1 0.4\nv 0.6 1 0.6\nv 0.4 1 0.6\nusemtl light\nf -4 -3 -2 -1\n";
    s
}

#[test]
fn million_faces_load_in_bounded_time_and_memory() {
    let dir = std::env::temp_dir().join(format!("vkrad-bad-million-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let t = Instant::now();
    let obj = grid_obj(1000);
    std::fs::write(dir.join("scene.obj"), &obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), MTL).unwrap();
    let bytes = obj.len();
    drop(obj);
    let generate = t.elapsed().as_secs_f64();

    let before = peak_rss().unwrap_or(0);
    let t = Instant::now();
    let scene = vkrad::scene::load(&dir.join("scene.obj")).expect("the grid loads");
    let secs = t.elapsed().as_secs_f64();
    let after = peak_rss().unwrap_or(0);
    std::fs::remove_dir_all(&dir).ok();

    assert_eq!(scene.patches.len(), 1_000_001);
    assert!(scene.warnings.is_empty(), "{:?}", &scene.warnings[..1]);
    let area: f64 = scene.patches.iter().map(|p| f64::from(p.area)).sum();
    assert!((area - 1.04).abs() < 1e-3, "{area}");
    println!(
        "1,000,001 faces ({:.1} MB of OBJ, generated in {generate:.2}s): loaded in {secs:.2}s, peak RSS {:.0} MB (was {:.0} MB before)",
        bytes as f64 / 1e6,
        after as f64 / 1e6,
        before as f64 / 1e6
    );
    // Debug builds of the loader run at opt-level 1; release takes ~10x less.
    assert!(secs < 60.0, "loading took {secs:.1}s");
    assert!(after < 3 << 30, "peak RSS {} MB", after >> 20);
}
