//! The `vkrad` binary end to end: good runs write whole files; bad input
//! ends with a clear message (file and line where there is one), a non-zero
//! exit, no panic and no output file.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the binary; `--validate` among `args` becomes `VKRAD_VALIDATE=1`,
/// which every command reads (the main command has no such flag).
fn vkrad(args: &[&str], dir: &Path) -> Output {
    let validate = args.contains(&"--validate");
    let args = args.iter().filter(|&&a| a != "--validate");
    Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args(args)
        .envs(validate.then_some(("VKRAD_VALIDATE", "1")))
        .current_dir(dir)
        .output()
        .expect("run vkrad")
}

use crate::common;

fn temp_dir(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("cli-{name}"))
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs vkrad on `obj` (and `mtl` as `scene.mtl`), expects failure with all
/// of `needles` in the message, and no image left behind.
fn expect_failure(name: &str, obj: &str, mtl: Option<&str>, needles: &[&str]) {
    let dir = temp_dir(name);
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    if let Some(mtl) = mtl {
        std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    }
    let out = vkrad(&["scene.obj", "-o", "out.png"], &dir);
    let err = stderr(&out);
    assert!(
        !out.status.success(),
        "{name}: expected failure, got success"
    );
    assert!(!err.contains("panicked"), "{name}: panicked:\n{err}");
    for n in needles {
        assert!(err.contains(n), "{name}: message lacks {n:?}:\n{err}");
    }
    assert!(!dir.join("out.png").exists(), "{name}: left an output file");
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "scene.obj" && n != "scene.mtl")
        .collect();
    assert!(leftovers.is_empty(), "{name}: left files {leftovers:?}");
    std::fs::remove_dir_all(&dir).ok();
}

const MTL: &str = "newmtl white\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0.5 0.5 0.5\nKe 5 5 5\n";
const GOOD_OBJ: &str = "mtllib scene.mtl\n\
v 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\n\
v 0 1 0\nv 1 1 0\nv 1 1 1\nv 0 1 1\n\
usemtl white\nf 1 2 3 4\nusemtl light\nf 5 6 7 8\n";

#[test]
fn missing_file() {
    let dir = temp_dir("missing");
    let out = vkrad(&["no/such/scene.obj"], &dir);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(
        err.contains("scene.obj") && !err.contains("panicked"),
        "{err}"
    );
}

/// Regression: the hint was printed twice, once run into the message.
#[test]
fn missing_scene_prints_its_hint_once() {
    let dir = temp_dir("missing-hint");
    let err = stderr(&vkrad(&["vise:"], &dir));
    assert_eq!(err.matches("hint: built-in scenes").count(), 1, "{err}");
    assert_eq!(err.matches("no such file").count(), 1, "{err}");
}

/// Regression: `--max-edge 1e-9` meshed 16 million elements and ran until
/// killed, and `--max-edge 1` built 6.75 million in 72 s. A mesh that cannot
/// fit is refused before meshing, with its size and what to do.
#[test]
fn a_mesh_that_cannot_fit_is_refused_before_meshing() {
    let dir = temp_dir("too-fine");
    for max_edge in ["1e-9", "1"] {
        let out = vkrad(&["cornell", "--max-edge", max_edge, "-o", "x.png"], &dir);
        let err = stderr(&out);
        assert!(!out.status.success(), "{err}");
        assert!(
            err.contains("would make") && err.contains("hint: use a larger --max-edge"),
            "{err}"
        );
        assert!(!dir.join("x.png").exists());
    }
}

/// Every built-in scene is named in `--help`.
#[test]
fn help_names_every_built_in_scene() {
    let dir = temp_dir("help");
    let out = vkrad(&["--help"], &dir);
    let help = String::from_utf8_lossy(&out.stdout).to_string();
    for name in vkrad::scene::builtin_names() {
        assert!(
            help.contains(&format!("{name},")) || help.contains(&format!("{name})")),
            "{name} missing from --help:\n{help}"
        );
    }
}

#[test]
fn malformed_vertex_names_its_line() {
    let obj = GOOD_OBJ.replace("v 1 0 1\n", "v 1 0\n");
    expect_failure("malformed", &obj, Some(MTL), &["scene.obj:4"]);
}

#[test]
fn nan_vertex_names_its_line() {
    let obj = GOOD_OBJ.replace("v 0 1 0\n", "v nan 1 0\n");
    expect_failure("nan", &obj, Some(MTL), &["scene.obj:6"]);
}

#[test]
fn index_out_of_range_names_its_line() {
    let obj = GOOD_OBJ.replace("f 5 6 7 8", "f 5 6 7 99");
    expect_failure("index", &obj, Some(MTL), &["scene.obj:13"]);
}

#[test]
fn missing_mtl_is_named() {
    expect_failure("nomtl", GOOD_OBJ, None, &["scene.mtl"]);
}

#[test]
fn no_emitter_is_an_error_with_a_hint() {
    let mtl = MTL.replace("Ke 5 5 5", "");
    expect_failure("noemitter", GOOD_OBJ, Some(&mtl), &["emitter", "Ke"]);
}

#[test]
fn degenerate_face_is_dropped_with_a_warning_naming_its_line() {
    // A zero-area face carries no light: dropped, and said where.
    let dir = temp_dir("degenerate");
    let obj = GOOD_OBJ.replace("f 1 2 3 4", "f 1 2 3 4\nf 1 1 1");
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), MTL).unwrap();
    let out = vkrad(&["scene.obj", "-o", "out.png", "--size", "16x16"], &dir);
    let all = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
    assert!(out.status.success(), "{all}");
    assert!(
        all.contains("zero-area") && all.contains("scene.obj:12"),
        "{all}"
    );
    assert!(dir.join("out.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unwritable_output_leaves_nothing() {
    let dir = temp_dir("unwritable");
    std::fs::write(dir.join("scene.obj"), GOOD_OBJ).unwrap();
    std::fs::write(dir.join("scene.mtl"), MTL).unwrap();
    for target in ["missing-folder/out.png", "scene.obj/out.png", "out.bmp"] {
        let out = vkrad(&["scene.obj", "-o", target], &dir);
        let err = stderr(&out);
        assert!(!out.status.success(), "{target}: expected failure");
        assert!(!err.contains("panicked"), "{err}");
        assert!(err.contains("out."), "{target}: {err}");
    }
    assert!(!dir.join("out.bmp").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn renders_and_exports_a_small_scene() {
    let dir = temp_dir("render");
    let out = vkrad(
        &[
            "simple",
            "-o",
            "simple.hdr",
            "--export",
            "simple.ply",
            "--size",
            "64x48",
            "--tune",
            "hemicube_res=32",
            "--validate",
        ],
        &dir,
    );
    let err = stderr(&out);
    assert!(out.status.success(), "vkrad failed:\n{err}");
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains("shots") && summary.contains("residual"),
        "{summary}"
    );
    let hdr = image::open(dir.join("simple.hdr")).unwrap();
    assert_eq!((hdr.width(), hdr.height()), (64, 48));
    let ply = std::fs::read_to_string(dir.join("simple.ply")).unwrap();
    assert!(ply.starts_with("ply\n"));
    assert!(ply.contains("property float radiosity_r"));
    assert!(ply.contains("property list uchar int vertex_indices"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--quality` orders the lit mesh: draft fewer display elements than
/// normal (at the solve's element size, two refinement passes), fine more;
/// the report names the level.
#[test]
fn quality_levels_order_the_lit_mesh() {
    let dir = temp_dir("quality");
    let mut elements = Vec::new();
    for level in ["draft", "normal", "fine"] {
        let report = format!("{level}.json");
        let out = vkrad(
            &[
                "simple",
                "-o",
                "simple.png",
                "--export",
                "simple.ply",
                "--size",
                "32x32",
                "--tune",
                "hemicube_res=32",
                "--quality",
                level,
                "--report",
                &report,
            ],
            &dir,
        );
        assert!(out.status.success(), "{level}:\n{}", stderr(&out));
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join(&report)).unwrap()).unwrap();
        assert_eq!(r["settings"]["quality"], level);
        let passes = r["display_mesh"]["refinement_passes"].as_array().unwrap();
        if level == "draft" {
            assert!(passes.len() <= 2, "draft refined {} times", passes.len());
        }
        elements.push(r["display_mesh"]["elements"].as_u64().unwrap());
    }
    assert!(
        elements[0] < elements[1] && elements[1] < elements[2],
        "display elements draft, normal, fine: {elements:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Images and meshes come out with the permissions the umask gives (issue
/// 19, item 6: they were rw------- whatever the umask, the atomic write's
/// temporary file's), and a file they replace keeps its own.
#[cfg(unix)]
#[test]
fn written_files_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("umask");
    let mode = |name: &str| {
        std::fs::metadata(dir.join(name))
            .unwrap()
            .permissions()
            .mode()
            & 0o7777
    };
    let run = |umask: &str| {
        // The shell sets the umask of the vkrad it runs, not of this process.
        let out = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "umask {umask} && exec \"$0\" simple -o simple.png --export simple.glb --size 32x24 --tune hemicube_res=32 --tune final_gather=false"
            ))
            .arg(env!("CARGO_BIN_EXE_vkrad"))
            .current_dir(&dir)
            .output()
            .expect("run vkrad through sh");
        assert!(out.status.success(), "vkrad failed:\n{}", stderr(&out));
    };
    for (umask, want) in [("0027", 0o640), ("0002", 0o664)] {
        let _ = std::fs::remove_file(dir.join("simple.png"));
        let _ = std::fs::remove_file(dir.join("simple.glb"));
        run(umask);
        assert_eq!(
            mode("simple.png"),
            want,
            "umask {umask}: {:o}",
            mode("simple.png")
        );
        assert_eq!(
            mode("simple.glb"),
            want,
            "umask {umask}: {:o}",
            mode("simple.glb")
        );
    }
    // Replaced files keep the mode they had.
    std::fs::set_permissions(
        dir.join("simple.png"),
        std::fs::Permissions::from_mode(0o604),
    )
    .unwrap();
    run("0077");
    assert_eq!(mode("simple.png"), 0o604);
    assert_eq!(mode("simple.glb"), 0o664);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn formfactors_json_is_a_square_matrix() {
    let dir = temp_dir("ff");
    let out = vkrad(
        &[
            "formfactors",
            "simple",
            "--json",
            "--tune",
            "hemicube_res=32",
            "--validate",
        ],
        &dir,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = doc["form_factors"].as_array().unwrap();
    let n = doc["patches"].as_array().unwrap().len();
    assert_eq!(m.len(), n);
    for row in m {
        let row = row.as_array().unwrap();
        assert_eq!(row.len(), n);
        let sum: f64 = row.iter().map(|f| f.as_f64().unwrap()).sum();
        assert!((0.0..=1.0 + 1e-6).contains(&sum), "row sum {sum}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn devices_lists_at_least_one() {
    let out = vkrad(&["devices"], &std::env::temp_dir());
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("[0]"));
}

#[test]
fn ctrl_c_stops_cleanly_and_writes_the_partial_result() {
    let dir = temp_dir("interrupt");
    let child = Command::new(env!("CARGO_BIN_EXE_vkrad"))
        .args([
            "cornell",
            "-o",
            "partial.png",
            "--size",
            "32x32",
            "--report",
            "run.json",
            // A solve far longer than the wait on any device (the default
            // stops early, the final gather's passes finishing the light;
            // an H200 reaches 1e-6 by hierarchical shots in under 3 s).
            "--tune",
            "converge=1e-12",
            "--tune",
            "shooting=element",
            "--tune",
            "max_shots=10000000",
        ])
        .current_dir(&dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough to be solving.
    std::thread::sleep(std::time::Duration::from_secs(3));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let summary = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(130), "{summary}\n{}", stderr(&out));
    assert!(summary.contains("PARTIAL"), "{summary}");
    assert!(dir.join("partial.png").exists());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).unwrap()).unwrap();
    assert_eq!(report["solve"]["interrupted"], true);
    assert!(report["solve"]["shots"].as_u64().unwrap() > 0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn blocked_light_warns_that_nothing_was_lit() {
    // The light (y = 2, facing down) shines onto the back of an occluder
    // (y = 1.9, also facing down), which hides the floor: nothing can receive.
    let dir = temp_dir("blocked");
    let obj = "mtllib scene.mtl\n\
        v 0.4 2 0.4\nv 0.6 2 0.4\nv 0.6 2 0.6\nv 0.4 2 0.6\n\
        v -5 1.9 -5\nv 5 1.9 -5\nv 5 1.9 5\nv -5 1.9 5\n\
        v -5 0 -5\nv -5 0 5\nv 5 0 5\nv 5 0 -5\n\
        usemtl light\nf 1 2 3 4\nusemtl white\nf 5 6 7 8\nf 9 10 11 12\n";
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), MTL).unwrap();
    let out = vkrad(
        &[
            "scene.obj",
            "-o",
            "out.png",
            "--size",
            "16x16",
            "--tune",
            "hemicube_res=16",
        ],
        &dir,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("no light reached"), "{summary}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The three methods through `vkrad formfactors`: hemicube and ray tracing
/// agree on the occluded light-to-floor factor of the simple scene; the
/// analytic (unoccluded) value is larger by the blocker's shadow.
#[test]
fn formfactor_methods_agree_where_they_should() {
    let dir = temp_dir("ffmethods");
    let light_to_floor = |ff: &str| -> f64 {
        let out = vkrad(&["formfactors", "simple", "--json", "--ff", ff], &dir);
        assert!(out.status.success(), "{ff}: {}", stderr(&out));
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let patches = doc["patches"].as_array().unwrap();
        let by_area = |pick_max: bool| {
            (0..patches.len())
                .max_by(|&a, &b| {
                    let (x, y) = (
                        patches[a]["area"].as_f64().unwrap(),
                        patches[b]["area"].as_f64().unwrap(),
                    );
                    if pick_max {
                        x.total_cmp(&y)
                    } else {
                        y.total_cmp(&x)
                    }
                })
                .unwrap()
        };
        // Light: the smallest patch; floor: the largest.
        doc["form_factors"][by_area(false)][by_area(true)]
            .as_f64()
            .unwrap()
    };
    let hemicube = light_to_floor("hemicube");
    let raytrace = light_to_floor("raytrace");
    let analytic = light_to_floor("analytic");
    assert!(
        (hemicube - raytrace).abs() / raytrace < 0.02,
        "{hemicube} vs {raytrace}"
    );
    assert!(
        analytic > raytrace * 1.05,
        "blocker shadow missing: {analytic} vs {raytrace}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn wireframe_darkens_mesh_edges() {
    let dir = temp_dir("wireframe");
    let run = |extra: &[&str], out: &str| {
        let mut args = vec![
            "simple",
            "-o",
            out,
            "--size",
            "64x48",
            "--tune",
            "hemicube_res=16",
            "--exposure",
            "4",
            "--tune",
            "mesh=discontinuity",
            "--tune",
            "subdivide=false",
            "--validate",
        ];
        args.extend_from_slice(extra);
        let o = vkrad(&args, &dir);
        assert!(o.status.success(), "{}", stderr(&o));
        image::open(dir.join(out)).unwrap().to_rgb8()
    };
    let plain = run(&[], "plain.png");
    let wire = run(&["--shade", "wireframe"], "wire.png");
    let darker = plain
        .pixels()
        .zip(wire.pixels())
        .filter(|(p, w)| w.0[1] + 12 < p.0[1])
        .count();
    assert!(darker > 20, "wireframe changed only {darker} pixels");
    std::fs::remove_dir_all(&dir).ok();
}

/// The exported mesh is the display mesh the final gather shaded (finer
/// than the solved one), and `--tune final_gather=false` exports the solved mesh.
#[test]
fn the_export_is_the_gathered_display_mesh() {
    let dir = temp_dir("display");
    let vertices = |extra: &[&str]| {
        let mut args = vec![
            "simple",
            "-o",
            "s.png",
            "--export",
            "s.ply",
            "--size",
            "32x24",
            "--tune",
            "hemicube_res=32",
            "--max-edge",
            "1.25",
            "--validate",
        ];
        args.extend_from_slice(extra);
        let out = vkrad(&args, &dir);
        assert!(out.status.success(), "{}", stderr(&out));
        let summary = String::from_utf8_lossy(&out.stdout).to_string();
        let ply = std::fs::read_to_string(dir.join("s.ply")).unwrap();
        let count: usize = ply
            .lines()
            .find_map(|l| l.strip_prefix("element vertex "))
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        (count, summary)
    };
    let (solved, plain) = vertices(&["--tune", "final_gather=false"]);
    let (display, gathered) = vertices(&["--tune", "display_mesh=uniform"]);
    // The summary's display line (the estimate's parts may name the
    // display mesh too).
    let display_line = |s: &str| s.lines().any(|l| l.trim_start().starts_with("display "));
    assert!(!display_line(&plain), "{plain}");
    assert!(display_line(&gathered), "{gathered}");
    // Half the edge: about four times the elements, more than twice the vertices.
    assert!(
        display > 2 * solved,
        "{display} display vertices vs {solved} solved"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Regression: without the final gather (`--tune final_gather=false`), a scene of many patches ran for over
/// 20 minutes (rfield) while its help said it was faster: the solve must
/// then shoot the light away on its own. vkrad says so, and how to bound
/// it; on a scene of a few patches it says nothing.
#[test]
fn no_final_gather_on_many_patches_warns_how_to_bound_the_solve() {
    let dir = temp_dir("no-gather");
    for (scene, warns) in [("vise", true), ("simple", false)] {
        let args = [
            scene,
            "-o",
            "x.png",
            "--size",
            "16x16",
            "--tune",
            "final_gather=false",
            "--tune",
            "max_shots=2",
        ];
        let out = vkrad(&args, &dir);
        assert!(out.status.success(), "{scene}:\n{}", stderr(&out));
        let said = stderr(&out).contains("--tune max_shots=N or --tune converge=F bounds it");
        assert_eq!(said, warns, "{scene}:\n{}", stderr(&out));
    }
}

/// Issue 45: an emitter written as glass (`illum 4`, as the public dining
/// room's `AreaLight`) was reported to stop `vkrad mesh --mesh
/// discontinuity` while the render only warned. Every command must warn
/// once, treat it as diffuse, and finish.
#[test]
fn transparent_emitter_is_diffuse_with_one_warning_in_every_command() {
    let dir = temp_dir("illum4");
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\n\
               newmtl AreaLight\nillum 4\nKd 1 1 1\nKa 0 0 0\nTf 1 1 1\nNi 1\nKs 0.5 0.5 0.5\nKe 5 5 5\n";
    // The floor, a blocker and the light: the discontinuity mesher has a
    // shadow to mesh.
    let obj = "mtllib scene.mtl\n\
               v 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\n\
               v 0.3 0.5 0.3\nv 0.3 0.5 0.7\nv 0.7 0.5 0.7\nv 0.7 0.5 0.3\n\
               v 0.4 1 0.4\nv 0.6 1 0.4\nv 0.6 1 0.6\nv 0.4 1 0.6\n\
               usemtl white\nf 1 2 3 4\nf 5 6 7 8\nusemtl AreaLight\nf 9 10 11 12\n";
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    let warning = "material \"AreaLight\" is transparent (illum 4";
    let runs: [&[&str]; 3] = [
        &[
            "mesh",
            "scene.obj",
            "--mesh",
            "discontinuity",
            "-o",
            "out.ply",
            "--validate",
        ],
        &["formfactors", "scene.obj", "--validate"],
        &[
            "scene.obj",
            "-o",
            "out.png",
            "--size",
            "16x12",
            "--tune",
            "hemicube_res=16",
            "--validate",
        ],
    ];
    for args in runs {
        let out = vkrad(args, &dir);
        let all = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
        assert!(out.status.success(), "{args:?} failed:\n{all}");
        assert_eq!(
            all.matches(warning).count(),
            1,
            "{args:?}: one warning:\n{all}"
        );
        assert!(all.contains("opaque and diffuse"), "{args:?}:\n{all}");
    }
    assert!(dir.join("out.ply").exists() && dir.join("out.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}
