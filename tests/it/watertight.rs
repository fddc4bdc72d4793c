//! Watertight by a check that reads the written file (issue 45): `vkrad mesh
//! SCENE --mesh discontinuity -o x.ply`, read back by a PLY reader of this
//! file's own and searched for T-junctions without any of the mesher's data
//! structures or tolerances.
//!
//! The file keeps one copy of a point per patch, so copies are first welded
//! (within f32 noise). A T-junction is then a crack's signature: a vertex
//! strictly inside an edge on one side of a line, where the other side
//! splits that line there. Only *unmatched* edges are searched: used an odd
//! number of times (once at a boundary or a crack; three times where a third
//! surface leans on a crack), since a matched edge (twice, or four times
//! where two solids share it) has the same points on both sides. The vertex
//! must also end an unmatched edge running along the searched one: a floor
//! vertex on the open bottom edge of a box standing on it is a contact, not
//! a crack, and its floor edges are matched.

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use crate::common;

/// A mesh as the file has it: positions and polygons (vertex indices).
struct PlyMesh {
    positions: Vec<[f64; 3]>,
    faces: Vec<Vec<usize>>,
}

/// Reads the ASCII PLY `vkrad` writes (x, y, z first; a vertex index list).
fn read_ply(path: &Path) -> PlyMesh {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("ply"), "{path:?}: not a PLY file");
    let (mut vertices, mut faces) = (None, None);
    for line in lines.by_ref() {
        match line.split_whitespace().collect::<Vec<_>>()[..] {
            ["format", f, _] => assert_eq!(f, "ascii", "{path:?}: only ASCII is read here"),
            ["element", "vertex", n] => vertices = n.parse::<usize>().ok(),
            ["element", "face", n] => faces = n.parse::<usize>().ok(),
            ["end_header"] => break,
            _ => {}
        }
    }
    let (vertices, faces) = (vertices.expect("vertex count"), faces.expect("face count"));
    let mut next = || lines.next().expect("a line the header promised");
    let positions = (0..vertices)
        .map(|_| {
            let w: Vec<f64> = next()
                .split_whitespace()
                .take(3)
                .map(|w| w.parse().expect("a coordinate"))
                .collect();
            [w[0], w[1], w[2]]
        })
        .collect();
    let faces = (0..faces)
        .map(|_| {
            let w: Vec<usize> = next()
                .split_whitespace()
                .map(|w| w.parse().expect("an index"))
                .collect();
            assert_eq!(w[0], w.len() - 1, "face vertex count");
            assert!(w[1..].iter().all(|&v| v < vertices), "index out of range");
            w[1..].to_vec()
        })
        .collect();
    PlyMesh { positions, faces }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cell(p: [f64; 3], size: f64) -> [i64; 3] {
    p.map(|x| (x / size).floor() as i64)
}

/// What the search found.
#[derive(Debug, Default)]
struct Junctions {
    /// Vertices strictly inside an unmatched edge, contacts included.
    on_unmatched_edges: usize,
    /// Those where the other side of the line splits it: the T-junctions.
    t_junctions: Vec<String>,
    unmatched_edges: usize,
}

/// Welds the copies of each point and finds the T-junctions (module doc).
fn t_junctions(mesh: &PlyMesh) -> Junctions {
    let pos = &mesh.positions;
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in pos {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = dot(sub(hi, lo), sub(hi, lo)).sqrt().max(f64::MIN_POSITIVE);
    let largest = lo.iter().chain(&hi).fold(0.0f64, |m, x| m.max(x.abs()));
    // Copies of one point differ by f32 rounding at most.
    let weld = (1e-7 * extent).max(8.0 * f64::from(f32::EPSILON) * largest);

    // Weld: each vertex to the first earlier one within `weld`.
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    let mut id: Vec<usize> = (0..pos.len()).collect();
    for (i, &p) in pos.iter().enumerate() {
        let c = cell(p, weld);
        let mut found = None;
        'near: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in grid
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .into_iter()
                        .flatten()
                    {
                        let d = sub(p, pos[j]);
                        if dot(d, d) <= weld * weld {
                            found = Some(id[j]);
                            break 'near;
                        }
                    }
                }
            }
        }
        match found {
            Some(j) => id[i] = j,
            None => grid.entry(c).or_default().push(i),
        }
    }

    // Edge uses over the welded vertices.
    let mut uses: HashMap<(usize, usize), u32> = HashMap::new();
    for f in &mesh.faces {
        for k in 0..f.len() {
            let (a, b) = (id[f[k]], id[f[(k + 1) % f.len()]]);
            if a != b {
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
    }
    let unmatched: Vec<(usize, usize)> = uses
        .iter()
        .filter(|&(_, &n)| n % 2 == 1)
        .map(|(&e, _)| e)
        .collect();
    let mut unmatched_at: HashMap<usize, Vec<usize>> = HashMap::new();
    for &(a, b) in &unmatched {
        unmatched_at.entry(a).or_default().push(b);
        unmatched_at.entry(b).or_default().push(a);
    }

    // The welded vertices in cells about a median unmatched edge long.
    let used: HashSet<usize> = uses.keys().flat_map(|&(a, b)| [a, b]).collect();
    let mut lengths: Vec<f64> = unmatched
        .iter()
        .map(|&(a, b)| dot(sub(pos[a], pos[b]), sub(pos[a], pos[b])).sqrt())
        .collect();
    lengths.sort_by(f64::total_cmp);
    let size = lengths
        .get(lengths.len() / 2)
        .copied()
        .unwrap_or(extent)
        .max(1e-4 * extent);
    let mut vertices: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for &v in &used {
        vertices.entry(cell(pos[v], size)).or_default().push(v);
    }

    let mut found = Junctions {
        unmatched_edges: unmatched.len(),
        ..Junctions::default()
    };
    for &(a, b) in &unmatched {
        let (pa, ab) = (pos[a], sub(pos[b], pos[a]));
        let len2 = dot(ab, ab);
        let len = len2.sqrt();
        let tol = 1e-5 * len + weld;
        // Distance of `p` from the line through a and b, and its parameter.
        let along = |p: [f64; 3]| {
            let ap = sub(p, pa);
            let t = dot(ap, ab) / len2;
            let off = sub(ap, ab.map(|x| x * t));
            (t, dot(off, off).sqrt())
        };
        // The cells along the edge, one margin cell around.
        let steps = (len / size).ceil() as usize + 1;
        let mut cells = HashSet::new();
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            let c = cell(
                [pa[0] + ab[0] * t, pa[1] + ab[1] * t, pa[2] + ab[2] * t],
                size,
            );
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        cells.insert([c[0] + dx, c[1] + dy, c[2] + dz]);
                    }
                }
            }
        }
        for v in cells
            .iter()
            .filter_map(|c| vertices.get(c))
            .flatten()
            .copied()
        {
            let (t, off) = along(pos[v]);
            if v == a || v == b || off > tol || t * len <= tol || (1.0 - t) * len <= tol {
                continue;
            }
            found.on_unmatched_edges += 1;
            let splits = unmatched_at.get(&v).into_iter().flatten().any(|&u| {
                let (_, off) = along(pos[u]);
                off <= tol
            });
            if splits {
                found.t_junctions.push(format!(
                    "{:?} inside {:?}-{:?} (t = {t:.4})",
                    pos[v], pos[a], pos[b]
                ));
            }
        }
    }
    found
}

/// `vkrad mesh SCENE --mesh discontinuity -o DIR/NAME.ply`, validated; the
/// written file.
fn mesh_to_ply(scene: &str, dir: &Path) -> PlyMesh {
    let name = Path::new(scene).file_stem().unwrap().to_string_lossy();
    let ply = dir.join(format!("{name}.ply"));
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args(["mesh", scene, "--mesh", "discontinuity", "-o"])
        .arg(&ply)
        .env("VKRAD_VALIDATE", "1")
        .output()
        .expect("run vkrad");
    assert!(
        out.status.success(),
        "vkrad mesh {scene}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{scene}: meshed in {:.1} s", t.elapsed().as_secs_f64());
    read_ply(&ply)
}

fn assert_watertight(scene: &str, dir: &Path) {
    let found = t_junctions(&mesh_to_ply(scene, dir));
    eprintln!(
        "{scene}: {} unmatched edges, {} vertices inside them, {} T-junctions",
        found.unmatched_edges,
        found.on_unmatched_edges,
        found.t_junctions.len()
    );
    assert!(
        found.t_junctions.is_empty(),
        "{scene}: {} T-junctions, the first: {:#?}",
        found.t_junctions.len(),
        &found.t_junctions[..found.t_junctions.len().min(10)]
    );
}

/// The check itself, on hand-made files: two squares sharing an edge, the
/// same with one side split at its midpoint (a T-junction), and a box
/// without a bottom standing on a floor that has a vertex under the middle
/// of one of its sides (a contact, not a crack).
#[test]
fn t_junction_check_finds_a_split_edge_and_passes_a_contact() {
    let dir = common::Scratch::new("watertight-self");
    let write = |name: &str, v: &[[f64; 3]], f: &[&[usize]]| {
        let mut s = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            v.len(),
            f.len()
        );
        for p in v {
            s += &format!("{} {} {}\n", p[0], p[1], p[2]);
        }
        for face in f {
            s += &format!("{}", face.len());
            for i in *face {
                s += &format!(" {i}");
            }
            s += "\n";
        }
        let path = dir.join(name);
        std::fs::write(&path, s).unwrap();
        t_junctions(&read_ply(&path))
    };
    // Left square 0-1-2-3, right square with its own copies of 1 and 2.
    let squares = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.5, 0.0],
    ];
    let shared = write("shared.ply", &squares, &[&[0, 1, 2, 3], &[4, 5, 6, 7]]);
    assert!(shared.t_junctions.is_empty(), "{shared:?}");
    assert_eq!(shared.unmatched_edges, 6);
    let split = write(
        "split.ply",
        &squares,
        &[&[0, 1, 2, 3], &[4, 5, 8], &[8, 5, 6], &[8, 6, 7]],
    );
    assert_eq!(split.t_junctions.len(), 1, "{split:?}");

    // A floor split along x = 0.5 (a contact line, as the mesher draws one)
    // with a vertex at (0.5, 0, 0.5) in the middle of the box's open
    // bottom edge from (0.5, 0, 0) to (0.5, 0, 1).
    let mut v = vec![
        [-1.0, 0.0, -1.0],
        [0.5, 0.0, -1.0],
        [0.5, 0.0, 0.5],
        [0.5, 0.0, 2.0],
        [-1.0, 0.0, 2.0],
        [2.0, 0.0, -1.0],
        [2.0, 0.0, 2.0],
    ];
    let mut faces: Vec<Vec<usize>> = [
        [0, 1, 2],
        [0, 2, 4],
        [2, 3, 4],
        [1, 5, 2],
        [2, 5, 6],
        [2, 6, 3],
    ]
    .map(|f| f.to_vec())
    .to_vec();
    // The box's four walls (1 high) on the square (0.5..1.5) x (0..1).
    let base = v.len();
    for p in [[0.5, 0.0], [1.5, 0.0], [1.5, 1.0], [0.5, 1.0]] {
        v.push([p[0], 0.0, p[1]]);
        v.push([p[0], 1.0, p[1]]);
    }
    for k in 0..4 {
        let (a, b) = (base + 2 * k, base + 2 * ((k + 1) % 4));
        faces.push(vec![a, b, b + 1, a + 1]);
    }
    faces.push((0..4).map(|k| base + 2 * k + 1).collect());
    let refs: Vec<&[usize]> = faces.iter().map(Vec::as_slice).collect();
    let contact = write("contact.ply", &v, &refs);
    assert!(contact.on_unmatched_edges >= 1, "{contact:?}");
    assert!(contact.t_junctions.is_empty(), "{contact:?}");
}

/// Small scenes, in CI: the Cornell box (boxes standing on the floor), the
/// extruded R, the thesis's fig. 21.
#[test]
fn discontinuity_meshes_read_back_have_no_t_junctions() {
    let dir = common::Scratch::new("watertight");
    for scene in ["simple", "cornell", "r"] {
        assert_watertight(scene, &dir);
    }
}

/// rfield (23,802 patches), the scene the issue names: most of a minute of
/// meshing on lavapipe in a test build, too long for every CI run, so on
/// demand: `cargo test --test it watertight -- --ignored`.
#[test]
#[ignore]
fn rfield_discontinuity_mesh_read_back_has_no_t_junctions() {
    let dir = common::Scratch::new("watertight-rfield");
    assert_watertight("rfield", &dir);
}
