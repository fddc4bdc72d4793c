//! glTF export (issue 19, item 5): the written `.glb` and `.gltf` are
//! parsed back here by hand, from the spec's layout: header, chunks, JSON,
//! accessors against buffer views against the buffer, and the values.

use std::path::Path;
use std::process::Command;

use serde_json::Value;
use vkrad::output::export_mesh;
use vkrad::output::tonemap::linear_to_srgb8;

use crate::common;

fn temp_dir(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("export-{name}"))
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

/// The JSON and BIN chunks of a `.glb`, after checking its framing.
pub(crate) fn read_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    assert!(bytes.len() >= 28, "{} bytes", bytes.len());
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(u32_at(bytes, 4), 2, "version");
    assert_eq!(u32_at(bytes, 8) as usize, bytes.len(), "total length");
    let json_len = u32_at(bytes, 12) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0, "JSON chunk padded to 4");
    let text = &bytes[20..20 + json_len];
    let trimmed = std::str::from_utf8(text).unwrap().trim_end_matches(' ');
    let json: Value = serde_json::from_str(trimmed).expect("the JSON chunk parses");
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bytes, bin_at) as usize;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(bin_len % 4, 0, "BIN chunk padded to 4");
    assert_eq!(bin_at + 8 + bin_len, bytes.len(), "nothing after BIN");
    (json, bytes[bin_at + 8..].to_vec())
}

fn unbase64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let mut out = Vec::new();
    for quad in text.as_bytes().chunks(4) {
        assert_eq!(quad.len(), 4, "base64 in quads");
        let pad = quad.iter().filter(|&&c| c == b'=').count();
        let n = quad[..4 - pad]
            .iter()
            .fold(0u32, |n, &c| (n << 6) | u32::from(value(c)))
            << (6 * pad);
        out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
    }
    out
}

/// The JSON and buffer of a `.gltf` with its buffer inline.
fn read_gltf(bytes: &[u8]) -> (Value, Vec<u8>) {
    let json: Value = serde_json::from_slice(bytes).expect("the .gltf parses");
    let uri = json["buffers"][0]["uri"].as_str().expect("a buffer uri");
    let data = uri
        .strip_prefix("data:application/octet-stream;base64,")
        .expect("a base64 data URI");
    let bin = unbase64(data);
    (json, bin)
}

/// The float VEC3s, or u32 scalars, an accessor holds: checked against its
/// buffer view and the buffer on the way.
fn accessor(json: &Value, bin: &[u8], index: &Value) -> (Vec<[f32; 3]>, Vec<u32>) {
    let a = &json["accessors"][index.as_u64().expect("an accessor index") as usize];
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    assert_eq!(view["buffer"], 0);
    let count = a["count"].as_u64().unwrap() as usize;
    assert!(count >= 1);
    let (width, ty, component) = match a["type"].as_str().unwrap() {
        "VEC3" => (12, "VEC3", 5126),
        "SCALAR" => (4, "SCALAR", 5125),
        other => panic!("unexpected accessor type {other}"),
    };
    assert_eq!(a["componentType"], component, "{ty}");
    let offset = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let length = view["byteLength"].as_u64().unwrap() as usize;
    assert_eq!(offset % 4, 0, "aligned");
    assert!(
        count * width <= length,
        "{count} x {width} in {length} bytes"
    );
    let buffer_length = json["buffers"][0]["byteLength"].as_u64().unwrap() as usize;
    assert!(view["byteOffset"].as_u64().unwrap_or(0) as usize + length <= buffer_length);
    assert!(buffer_length <= bin.len());
    let bytes = &bin[offset..offset + count * width];
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
        .collect();
    if ty == "VEC3" {
        let floats: Vec<f32> = words.iter().map(|&w| f32::from_bits(w)).collect();
        (
            floats.chunks_exact(3).map(|v| [v[0], v[1], v[2]]).collect(),
            vec![],
        )
    } else {
        (vec![], words)
    }
}

/// What a parsed export holds.
struct Parsed {
    json: Value,
    positions: Vec<[f32; 3]>,
    colours: Vec<[f32; 3]>,
    radiosity: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

/// Checks everything the spec asks of our one primitive and returns it.
fn check(json: Value, bin: &[u8]) -> Parsed {
    assert_eq!(json["asset"]["version"], "2.0");
    let used = json["extensionsUsed"].as_array().unwrap();
    assert!(used.iter().any(|e| e == "KHR_materials_unlit"));
    let material = &json["materials"][0];
    assert!(material["extensions"]["KHR_materials_unlit"].is_object());
    assert_eq!(
        material["pbrMetallicRoughness"]["baseColorFactor"],
        serde_json::json!([1.0, 1.0, 1.0, 1.0])
    );
    assert_eq!(json["scenes"][0]["nodes"][0], 0);
    assert_eq!(json["nodes"][0]["mesh"], 0);
    let primitive = &json["meshes"][0]["primitives"][0];
    assert_eq!(primitive["mode"], 4);
    assert_eq!(primitive["material"], 0);
    let attr = &primitive["attributes"];
    let (positions, _) = accessor(&json, bin, &attr["POSITION"]);
    let (normals, _) = accessor(&json, bin, &attr["NORMAL"]);
    let (colours, _) = accessor(&json, bin, &attr["COLOR_0"]);
    let (radiosity, _) = accessor(&json, bin, &attr["_RADIOSITY"]);
    let (_, indices) = accessor(&json, bin, &primitive["indices"]);
    let n = positions.len();
    assert_eq!(normals.len(), n);
    assert_eq!(colours.len(), n);
    assert_eq!(radiosity.len(), n);
    assert_eq!(indices.len() % 3, 0);
    assert!(
        indices.iter().all(|&i| (i as usize) < n),
        "indices in range"
    );
    // POSITION's min and max are required and must be exact.
    let pos = &json["accessors"][attr["POSITION"].as_u64().unwrap() as usize];
    for k in 0..3 {
        let lo = positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min);
        let hi = positions
            .iter()
            .map(|p| p[k])
            .fold(f32::NEG_INFINITY, f32::max);
        assert_eq!(pos["min"][k].as_f64().unwrap() as f32, lo);
        assert_eq!(pos["max"][k].as_f64().unwrap() as f32, hi);
    }
    for m in &normals {
        let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-4, "normal {m:?}");
    }
    for c in colours.iter().flatten() {
        assert!((0.0..=1.0).contains(c), "COLOR_0 component {c}");
    }
    // Triangles face the way their normals do (counter-clockwise).
    let v = |i: u32| glam::Vec3::from(positions[i as usize]);
    for t in indices.chunks_exact(3) {
        let face = (v(t[1]) - v(t[0])).cross(v(t[2]) - v(t[0]));
        let normal = glam::Vec3::from(normals[t[0] as usize]);
        assert!(face.dot(normal) >= 0.0, "triangle {t:?} faces away");
    }
    Parsed {
        json,
        positions,
        colours,
        radiosity,
        indices,
    }
}

fn read(path: &Path) -> Parsed {
    let bytes = std::fs::read(path).unwrap();
    let (json, bin) = match path.extension().and_then(|e| e.to_str()) {
        Some("glb") => read_glb(&bytes),
        _ => read_gltf(&bytes),
    };
    check(json, &bin)
}

/// The Cornell box's uniform mesh with a made-up radiosity that spans
/// black to far over white, exported as `.glb`, `.gltf` and `.ply`: the
/// three agree, and COLOR_0 is the PLY's 8-bit colour before its sRGB
/// transfer.
#[test]
fn glb_and_gltf_hold_the_mesh_and_agree_with_the_ply() {
    let dir = temp_dir("formats");
    let scene = vkrad::scene::load_builtin("cornell").unwrap().unwrap();
    let mesh = vkrad::mesh::uniform(&scene, 60.0);
    let radiosity: Vec<[f32; 3]> = mesh
        .vertices
        .iter()
        .map(|p| [p.x * 0.02, p.y * 0.01, p.z * 0.003])
        .collect();
    let exposure = 0.7;
    for name in ["m.glb", "m.gltf", "m.ply"] {
        export_mesh(&dir.join(name), &mesh, &radiosity, exposure).unwrap();
    }
    let glb = read(&dir.join("m.glb"));
    let gltf = read(&dir.join("m.gltf"));
    assert_eq!(glb.json, {
        let mut j = gltf.json.clone();
        j["buffers"][0].as_object_mut().unwrap().remove("uri");
        j
    });
    assert_eq!(glb.positions, gltf.positions);
    assert_eq!(glb.indices, gltf.indices);
    let n = mesh.vertices.len();
    assert_eq!(glb.positions.len(), n);
    assert_eq!(glb.indices.len(), mesh.triangle_count() * 3);
    assert_eq!(glb.radiosity, radiosity, "linear radiosity, bit for bit");
    assert!(glb.colours.iter().flatten().any(|&c| c == 1.0), "clamped");
    assert!(glb.colours.iter().flatten().any(|&c| c > 0.0 && c < 1.0));
    assert_eq!(
        glb.json["meshes"][0]["extras"]["exposure"]
            .as_f64()
            .unwrap() as f32,
        exposure
    );
    let ply = std::fs::read_to_string(dir.join("m.ply")).unwrap();
    let body = ply.split_once("end_header\n").unwrap().1;
    for (line, c) in body.lines().take(n).zip(&glb.colours) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let rgb: Vec<u8> = f[3..6].iter().map(|s| s.parse().unwrap()).collect();
        assert_eq!(rgb, c.map(linear_to_srgb8).to_vec(), "{line}");
    }
    let files: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(files.len(), 3, "no temporary files left");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `vkrad --export scene.glb` end to end: the colours use the image's
/// exposure.
#[test]
fn the_binary_exports_glb_with_the_image_exposure() {
    let dir = temp_dir("cli");
    let out = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "simple",
            "-o",
            "s.png",
            "--export",
            "s.glb",
            "--size",
            "32x24",
            "--tune",
            "hemicube_res=16",
            "--tune",
            "final_gather=false",
        ])
        .env("VKRAD_VALIDATE", "1")
        .current_dir(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let glb = read(&dir.join("s.glb"));
    let shown: f32 = stdout
        .split("exposure ")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no exposure in {stdout}"));
    let written = glb.json["meshes"][0]["extras"]["exposure"]
        .as_f64()
        .unwrap() as f32;
    assert!(
        (written - shown).abs() <= 1e-3 * shown,
        "{written} vs {shown}"
    );
    assert!(glb.colours.iter().flatten().any(|&c| c > 0.0));
    // The extension check runs before any work.
    let bad = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args(["simple", "-o", "t.png", "--export", "t.gltf2"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("glb"));
    std::fs::remove_dir_all(&dir).unwrap();
}
