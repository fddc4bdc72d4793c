//! The committed SPIR-V in `spirv/` is exactly what glslang makes of `glsl/`,
//! and passes `spirv-val`. To regenerate after editing a shader:
//!
//!     VKRAD_BLESS_SPIRV=1 cargo test --test it shaders::
//!
//! (needs `glslangValidator` and `spirv-val`: apt-get install glslang-tools spirv-tools)

use std::path::{Path, PathBuf};
use std::process::Command;

/// SPIR-V 1.5: Vulkan 1.3's SPIR-V 1.6 would use LocalSizeId, which needs
/// the maintenance4 feature; 1.5 runs on every Vulkan 1.3 device.
const TARGET_ENV: &str = "vulkan1.2";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tool(name: &str) -> String {
    let found = Command::new(name).arg("--version").output().is_ok();
    assert!(
        found,
        "{name} is not installed; apt-get install glslang-tools spirv-tools"
    );
    name.to_owned()
}

fn shader_sources() -> Vec<PathBuf> {
    let mut sources: Vec<PathBuf> = std::fs::read_dir(root().join("glsl"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("vert" | "frag" | "comp")
            )
        })
        .collect();
    sources.sort();
    sources
}

fn spv_path(source: &Path) -> PathBuf {
    let name = source.file_name().unwrap().to_string_lossy();
    root().join("spirv").join(format!("{name}.spv"))
}

#[test]
fn committed_spirv_matches_glsl() {
    let glslang = tool("glslangValidator");
    let bless = std::env::var_os("VKRAD_BLESS_SPIRV").is_some();
    let tmp = std::env::temp_dir().join(format!("vkrad-spirv-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let mut stale = vec![];
    for source in shader_sources() {
        let out = tmp.join(source.file_name().unwrap());
        let status = Command::new(&glslang)
            .arg("-V")
            .args(["--target-env", TARGET_ENV])
            .arg("-I".to_string() + &root().join("glsl").display().to_string())
            .arg("-o")
            .arg(&out)
            .arg(&source)
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{} does not compile:\n{}",
            source.display(),
            String::from_utf8_lossy(&status.stdout)
        );
        let fresh = std::fs::read(&out).unwrap();
        let committed_path = spv_path(&source);
        if bless {
            std::fs::write(&committed_path, &fresh).unwrap();
        } else if std::fs::read(&committed_path).ok().as_deref() != Some(&fresh[..]) {
            stale.push(committed_path.display().to_string());
        }
    }
    std::fs::remove_dir_all(&tmp).ok();
    assert!(
        stale.is_empty(),
        "committed SPIR-V is out of date: {stale:?}\n  regenerate: VKRAD_BLESS_SPIRV=1 cargo test --test it shaders::"
    );
}

#[test]
fn every_module_has_a_source_and_passes_spirv_val() {
    let val = tool("spirv-val");
    let sources = shader_sources();
    let mut modules = 0;
    for entry in std::fs::read_dir(root().join("spirv")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let source = root().join("glsl").join(name.trim_end_matches(".spv"));
        assert!(sources.contains(&source), "{name} has no GLSL source");
        let out = Command::new(&val)
            .args(["--target-env", TARGET_ENV])
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "spirv-val rejects {name}:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        modules += 1;
    }
    assert_eq!(
        modules,
        sources.len(),
        "a GLSL source has no committed module"
    );
}
