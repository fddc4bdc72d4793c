//! Lightmaps (`--lightmap`, issue 44 item 3): the exported `.glb` is read
//! back, its atlas decoded and sampled (bilinearly, as a viewer filters)
//! at the vertices' `TEXCOORD_1`, against the vertex colours; the two
//! sides of every chart seam; the refusal without a glTF export; the
//! Khronos validator where node and `tools/lightmap`'s npm packages are.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

use serde_json::Value;
use vkrad::app::{run, Job};
use vkrad::output::lightmap::{Bake, Density};
use vkrad::output::mesh_export::export_textured_mesh;
use vkrad::output::tonemap::linear_to_srgb8;

use crate::common;
use crate::export::read_glb;

/// What a lightmapped `.glb` holds.
struct Baked {
    json: Value,
    positions: Vec<[f32; 3]>,
    uv0: Vec<[f32; 2]>,
    uv1: Vec<[f32; 2]>,
    colours: Vec<[f32; 3]>,
    indices: Vec<u32>,
    atlas: image::RgbImage,
}

fn floats(json: &Value, bin: &[u8], accessor: &Value, width: usize) -> Vec<f32> {
    let a = &json["accessors"][accessor.as_u64().unwrap() as usize];
    assert_eq!(a["componentType"], 5126);
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let count = a["count"].as_u64().unwrap() as usize;
    bin[at..at + count * width * 4]
        .chunks_exact(4)
        .map(|w| f32::from_le_bytes(w.try_into().unwrap()))
        .collect()
}

fn read(path: &Path) -> Baked {
    let (json, bin) = read_glb(&std::fs::read(path).unwrap());
    let primitive = &json["meshes"][0]["primitives"][0];
    let attr = &primitive["attributes"];
    assert!(
        attr.get("COLOR_0").is_none(),
        "COLOR_0 would multiply the atlas"
    );
    let vec2 = |key: &str| -> Vec<[f32; 2]> {
        floats(&json, &bin, &attr[key], 2)
            .chunks_exact(2)
            .map(|c| [c[0], c[1]])
            .collect()
    };
    let vec3 = |key: &str| -> Vec<[f32; 3]> {
        floats(&json, &bin, &attr[key], 3)
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect()
    };
    let index = &json["accessors"][primitive["indices"].as_u64().unwrap() as usize];
    let view = &json["bufferViews"][index["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap() as usize;
    let indices = bin[at..at + index["count"].as_u64().unwrap() as usize * 4]
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
        .collect();
    // The material shows the atlas through TEXCOORD_0, unlit.
    let material = &json["materials"][primitive["material"].as_u64().unwrap() as usize];
    assert!(material["extensions"]["KHR_materials_unlit"].is_object());
    let texture = &material["pbrMetallicRoughness"]["baseColorTexture"];
    assert_eq!(texture["texCoord"].as_u64().unwrap_or(0), 0);
    let image = &json["images"][json["textures"][texture["index"].as_u64().unwrap() as usize]
        ["source"]
        .as_u64()
        .unwrap() as usize];
    assert_eq!(image["mimeType"], "image/png");
    let view = &json["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap() as usize;
    let png = &bin[at..at + view["byteLength"].as_u64().unwrap() as usize];
    let atlas = image::load_from_memory_with_format(png, image::ImageFormat::Png)
        .unwrap()
        .to_rgb8();
    let baked = Baked {
        positions: vec3("POSITION"),
        uv0: vec2("TEXCOORD_0"),
        uv1: vec2("TEXCOORD_1"),
        colours: vec3("_COLOR_0"),
        indices,
        atlas,
        json,
    };
    assert_eq!(baked.uv0, baked.uv1, "TEXCOORD_0 repeats TEXCOORD_1");
    assert_eq!(baked.uv1.len(), baked.positions.len());
    let lightmap = &baked.json["meshes"][0]["extras"]["lightmap"];
    assert_eq!(lightmap["width"], baked.atlas.width());
    assert_eq!(lightmap["height"], baked.atlas.height());
    baked
}

impl Baked {
    /// Bilinear sample of the 8-bit atlas at glTF `uv` (edge clamped).
    fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        let (w, h) = (self.atlas.width() as f32, self.atlas.height() as f32);
        let (x, y) = (uv[0] * w - 0.5, uv[1] * h - 0.5);
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let texel = |x: f32, y: f32| {
            let p = self
                .atlas
                .get_pixel(x.clamp(0.0, w - 1.0) as u32, y.clamp(0.0, h - 1.0) as u32);
            p.0.map(f32::from)
        };
        let taps = [
            (texel(fx, fy), (1.0 - tx) * (1.0 - ty)),
            (texel(fx + 1.0, fy), tx * (1.0 - ty)),
            (texel(fx, fy + 1.0), (1.0 - tx) * ty),
            (texel(fx + 1.0, fy + 1.0), tx * ty),
        ];
        std::array::from_fn(|c| taps.iter().map(|(t, w)| t[c] * w).sum())
    }

    /// Per vertex, the largest channel difference (8-bit sRGB levels)
    /// between the atlas at its TEXCOORD_1 and its vertex colour.
    fn vertex_errors(&self) -> Vec<f32> {
        self.uv1
            .iter()
            .zip(&self.colours)
            .map(|(&uv, c)| {
                let s = self.sample(uv);
                (0..3)
                    .map(|k| (s[k] - f32::from(linear_to_srgb8(c[k]))).abs())
                    .fold(0.0, f32::max)
            })
            .collect()
    }
}

fn percentile(mut v: Vec<f32>, p: f64) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// The Cornell box lit as `vkrad cornell --export x.glb --lightmap auto`
/// does: the atlas at each vertex's TEXCOORD_1 shows its vertex colour.
/// Bilinear filtering reads the texels within a texel of the vertex, so
/// where the light changes fast (penumbrae, contacts, at auto's about 4
/// texels per display vertex) a vertex and its atlas differ by the
/// change over a texel: the bounds are on the median (1 level of 255),
/// the 90th percentile (3) and the 99th (80); measured on lavapipe:
/// 0.37, 1.20 and 53.4 (with two display refinement passes, whose
/// penumbrae kept fewer vertices where the light changes within a texel,
/// 0.35, 0.90 and 29.5). A wrong chart placement,
/// a flipped axis or an unfilled gutter puts most vertices far off.
#[test]
fn the_cornell_atlas_shows_the_vertex_colours() {
    let dir = common::Scratch::new("lightmap-cornell");
    let device = common::device();
    let mut job = Job::new("cornell");
    job.output = Some(dir.join("c.png"));
    job.export = Some(dir.join("c.glb"));
    job.lightmap = Some(Density::Auto);
    job.size = (48, 48);
    let report = run(&job, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    let baked = read(&dir.join("c.glb"));
    let lightmap = &baked.json["meshes"][0]["extras"]["lightmap"];
    // Beside it, the same atlas linear and unclamped: tone-mapped as the
    // PNG is, it is the PNG (within a level), and the light's texels keep
    // what the clamp cuts.
    assert_eq!(lightmap["hdr"], "c.lightmap.exr");
    let hdr = image::open(dir.join("c.lightmap.exr")).unwrap().to_rgb32f();
    assert_eq!(hdr.dimensions(), baked.atlas.dimensions());
    let mut brightest = 0.0f32;
    for (l, png) in hdr.pixels().map(|p| p.0).zip(baked.atlas.pixels()) {
        for c in 0..3 {
            let exposed = l[c] * report.exposure;
            brightest = brightest.max(exposed);
            let level = f32::from(linear_to_srgb8(exposed));
            assert!((level - f32::from(png.0[c])).abs() <= 1.0, "{l:?} {png:?}");
        }
    }
    assert!(brightest > 2.0, "the light's texels are HDR: {brightest}");
    let covered = lightmap["covered_texels"].as_f64().unwrap();
    let vertices = lightmap["input_vertices"].as_f64().unwrap();
    assert!(
        (2.0..16.0).contains(&(covered / vertices)),
        "auto: {covered} texels for {vertices} display vertices"
    );
    let errors = baked.vertex_errors();
    let (p50, p90, p99) = (
        percentile(errors.clone(), 0.5),
        percentile(errors.clone(), 0.9),
        percentile(errors, 0.99),
    );
    eprintln!("atlas vs vertex colour, sRGB levels: median {p50}, p90 {p90}, p99 {p99}");
    assert!(p50 <= 1.0 && p90 <= 3.0 && p99 <= 80.0, "{p50} {p90} {p99}");
    validate(&dir.join("c.glb"));
}

/// Chart seams: the cornell mesh with a radiosity affine in position (the
/// same value at a point whichever patch its vertex belongs to), so the
/// two sides of every seam interpolate the same values along it. Points
/// along each seam edge, sampled bilinearly in both charts, agree within
/// 3 levels of 255 (bilinear reads up to about a texel off the edge on
/// each side, where the field differs by under a level).
#[test]
fn the_two_sides_of_every_seam_agree() {
    let dir = common::Scratch::new("lightmap-seams");
    let scene = vkrad::scene::load_builtin("cornell").unwrap().unwrap();
    let mesh = vkrad::mesh::uniform(&scene, 60.0);
    let radiosity: Vec<[f32; 3]> = mesh
        .vertices
        .iter()
        .map(|p| [0.5 + p.x * 0.003, 0.4 + p.y * 0.004, 0.9 - p.z * 0.0015])
        .collect();
    let path = dir.join("s.glb");
    export_textured_mesh(
        &path,
        &mesh,
        &radiosity,
        1.0,
        None,
        Some(Bake {
            density: Density::TexelsPerUnit(0.5),
            shade: None,
        }),
    )
    .unwrap();
    let baked = read(&path);
    let key = |v: u32| baked.positions[v as usize].map(|c| (c * 16.0).round() as i64);
    // Every edge by its ends' positions: (ends' vertices) per side.
    let mut edges: HashMap<_, Vec<(u32, u32)>> = HashMap::new();
    for t in baked.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            let (a, b) = if ka < kb { (a, b) } else { (b, a) };
            edges
                .entry((ka.min(kb), ka.max(kb)))
                .or_default()
                .push((a, b));
        }
    }
    let (mut seams, mut worst) = (0, 0.0f32);
    for sides in edges.values() {
        for (i, &(a0, b0)) in sides.iter().enumerate() {
            for &(a1, b1) in &sides[i + 1..] {
                if baked.uv1[a0 as usize] == baked.uv1[a1 as usize] {
                    continue; // one chart
                }
                seams += 1;
                for k in 1..10 {
                    let t = k as f32 / 10.0;
                    let at = |a: u32, b: u32| {
                        let (p, q) = (baked.uv1[a as usize], baked.uv1[b as usize]);
                        baked.sample([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t])
                    };
                    let (s0, s1) = (at(a0, b0), at(a1, b1));
                    for c in 0..3 {
                        worst = worst.max((s0[c] - s1[c]).abs());
                    }
                }
            }
        }
    }
    eprintln!("{seams} seam edges, worst difference {worst} levels");
    assert!(seams >= 12 * 4, "the box's creases are seams: {seams}");
    assert!(worst <= 3.0, "seam sides differ by {worst} levels of 255");
}

/// A textured scene's atlas shows its textures lit (issue 44, item 3): the
/// room of `textures.rs`, its back wall striped black and white, baked at
/// 16 texels a unit (a stripe is 16 texels wide). Along the middle row of
/// the image, the atlas at each column's point of the wall is within 6
/// levels of 255 of the image (`--shade mesh`: the same lit texture;
/// measured 0.6) on the white stripes, and black on the black ones; away
/// from the stripes' edges, where a texel averages both.
#[test]
fn a_textured_scene_s_atlas_shows_its_textures_lit() {
    let dir = common::Scratch::new("lightmap-textured");
    crate::textures::stripes(&dir);
    let scene =
        vkrad::scene::load(&crate::textures::room(&dir, "map_Kd stripes.png", 0.8)).unwrap();
    let device = common::device();
    let mut job = Job::new("room");
    job.output = Some(dir.join("room.png"));
    job.export = Some(dir.join("room.glb"));
    job.lightmap = Some(Density::TexelsPerUnit(16.0));
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    job.size = (96, 96);
    let report = vkrad::app::run_scene(&job, scene, 0.0, Some(device.clone()), |_| true).unwrap();
    common::assert_validation_clean(&device);
    let baked = read(&dir.join("room.glb"));
    // The atlas at a point of the wall (z = 0, facing +z): its triangle
    // among the exported ones, and TEXCOORD_1 there.
    let atlas_at = |x: f32, y: f32| -> Option<[f32; 3]> {
        for t in baked.indices.chunks_exact(3) {
            let p = [0, 1, 2].map(|k| baked.positions[t[k] as usize]);
            if p.iter().any(|p| p[2].abs() > 1e-4) {
                continue;
            }
            let area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
            if area <= 0.0 {
                continue;
            }
            let edge =
                |a: [f32; 3], b: [f32; 3]| (b[0] - a[0]) * (y - a[1]) - (x - a[0]) * (b[1] - a[1]);
            let w = [
                edge(p[1], p[2]) / area,
                edge(p[2], p[0]) / area,
                edge(p[0], p[1]) / area,
            ];
            if w.iter().all(|&w| w >= -1e-6) {
                let uv = [0, 1].map(|c| (0..3).map(|k| w[k] * baked.uv1[t[k] as usize][c]).sum());
                return Some(baked.sample(uv));
            }
        }
        None
    };
    let (w, h) = (report.image.width, report.image.height);
    let row = h / 2;
    let (mut white, mut black, mut worst) = (0, 0, 0.0f32);
    for x in 0..w {
        let u = crate::textures::u_at_column(x, w);
        let edge = (u * 4.0 - (u * 4.0).round()).abs() / 4.0;
        if !(0.0..1.0).contains(&u) || edge < 0.03 {
            continue;
        }
        let atlas = atlas_at(4.0 * u, 2.0).expect("the wall's point is in a triangle");
        let image = report.image.pixels[(row * w + x) as usize]
            .map(|l| linear_to_srgb8(l * report.exposure));
        if ((u * 4.0) as u32) % 2 == 1 {
            for c in 0..3 {
                let off = (atlas[c] - f32::from(image[c])).abs();
                assert!(
                    off <= 6.0,
                    "column {x} (u {u}): atlas {atlas:?}, image {image:?}"
                );
                worst = worst.max(off);
            }
            assert!(atlas[0] > 16.0, "a white stripe is lit: {atlas:?}");
            white += 1;
        } else {
            assert!(
                atlas.iter().all(|&c| c <= 1.0),
                "column {x} (u {u}): {atlas:?} where black"
            );
            black += 1;
        }
    }
    eprintln!(
        "{white} white columns, the atlas at most {worst} levels off the image; {black} black"
    );
    assert!(
        white >= 20 && black >= 20,
        "{white} white and {black} black columns"
    );
    validate(&dir.join("room.glb"));
}

/// `--lightmap` needs a glTF export: without one, or with `.ply`, the run
/// stops at once with an error naming the setting.
#[test]
fn a_lightmap_without_a_gltf_export_is_refused() {
    let dir = common::Scratch::new("lightmap-refused");
    for extra in [&[][..], &["--export", "x.ply"], &["--export", "x.obj"]] {
        let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
            .args(["cornell", "-o", "x.png", "--lightmap", "auto"])
            .args(extra)
            .current_dir(&dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?}");
        assert!(
            stderr.contains("--lightmap auto needs --export FILE.glb or FILE.gltf"),
            "{extra:?}: {stderr}"
        );
        assert!(
            std::fs::read_dir(&dir).unwrap().next().is_none(),
            "no work done"
        );
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args(["cornell", "--export", "x.glb", "--lightmap", "0"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("texels per scene unit"));
    // Too dense for any atlas: said before the solve, not after it (the
    // Cornell box's surface is about 1.9 million square units: at most
    // about 2.9 texels per unit fit in 4096 x 4096).
    let dense = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "cornell",
            "--export",
            "x.glb",
            "--lightmap",
            "8",
            "-o",
            "x.png",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&dense.stderr);
    assert!(!dense.status.success(), "{stderr}");
    assert!(stderr.contains("texels per unit can fit"), "{stderr}");
    assert!(
        std::fs::read_dir(&dir).unwrap().next().is_none(),
        "no work done"
    );
}

/// The Khronos glTF validator on `path`, where node and the npm package
/// (`npm ci` in tools/lightmap) are installed; errors fail the test.
fn validate(path: &Path) {
    let tools = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/lightmap");
    if !tools.join("node_modules/gltf-validator").is_dir() {
        eprintln!("note: glTF validator skipped: run `npm ci` in tools/lightmap (needs node)");
        return;
    }
    let out = match Command::new("node")
        .arg(tools.join("validate.js"))
        .arg(path)
        .output()
    {
        Ok(out) => out,
        Err(e) => {
            eprintln!("note: glTF validator skipped: no node ({e})");
            return;
        }
    };
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the glTF validator: {report}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let issues: Value = serde_json::from_str(report.trim()).unwrap();
    assert_eq!(issues["numErrors"], 0, "{issues}");
    assert_eq!(issues["numWarnings"], 0, "{issues}");
}
