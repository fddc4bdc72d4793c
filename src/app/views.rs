//! Many views from one solve (`--views cameras.json`): the lit mesh, the
//! view-independent solution, rasterized from every camera in a file.
//!
//! ```json
//! { "views": [
//!     { "eye": [0, 1, 3.5], "look_at": [0, 1, 0], "output": "front.png" },
//!     { "eye": [0.9, 0.3, 0.5], "fov": 60 }
//! ] }
//! ```
//!
//! A bare list of views is accepted too. A view's `eye`, `look_at`, `up`
//! (three numbers) and `fov` (vertical, degrees) default to the main
//! camera's; `output` defaults to the main image's name with `-viewN`
//! added (N counts from 1).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde_json::Value;

use super::{check_output_path, CameraOverride, Job, IMAGE_EXTENSIONS};
use crate::error::{Error, Result};
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::output::image_io::save_image;
use crate::render::LitMeshImages;
use crate::scene::{Camera, Scene};

/// One camera of a views file and the image it writes.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    pub camera: CameraOverride,
    pub output: PathBuf,
}

/// The views in the file at `path`; unnamed outputs are named after
/// `main_output`. Every output path is checked before any work.
pub fn load_views(path: &Path, main_output: &Path) -> Result<Vec<View>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_views(path, &text, main_output)
}

/// [`load_views`] on the text of a views file (`path` names it in errors).
pub fn parse_views(path: &Path, text: &str, main_output: &Path) -> Result<Vec<View>> {
    let bad = |what: String| Error::Invalid(format!("{}: {what}", path.display()));
    let value: Value = serde_json::from_str(text).map_err(|e| {
        bad(format!(
            "not JSON (line {}, column {}): {e}",
            e.line(),
            e.column()
        ))
    })?;
    let list = match &value {
        Value::Array(list) => list,
        Value::Object(o) => match o.get("views") {
            Some(Value::Array(list)) => list,
            _ => {
                return Err(bad(
                    "expected {\"views\": [ ... ]} or a list of views".into()
                ))
            }
        },
        _ => {
            return Err(bad(
                "expected {\"views\": [ ... ]} or a list of views".into()
            ))
        }
    };
    if list.is_empty() {
        return Err(bad("the file lists no views".into()));
    }
    let mut views = Vec::with_capacity(list.len());
    for (i, entry) in list.iter().enumerate() {
        let n = i + 1;
        let at = |what: String| bad(format!("view {n}: {what}"));
        let Value::Object(fields) = entry else {
            return Err(at(
                "expected an object with eye, look_at, up, fov, output".into()
            ));
        };
        for key in fields.keys() {
            if !["eye", "look_at", "up", "fov", "output"].contains(&key.as_str()) {
                return Err(at(format!(
                    "unknown field {key:?}; known: eye, look_at, up, fov, output"
                )));
            }
        }
        let vec3 = |key: &str| -> Result<Option<glam::Vec3>> {
            match fields.get(key) {
                None => Ok(None),
                Some(v) => three_numbers(v)
                    .map(Some)
                    .ok_or_else(|| at(format!("{key:?} must be three finite numbers, got {v}"))),
            }
        };
        let camera = CameraOverride {
            eye: vec3("eye")?,
            look_at: vec3("look_at")?,
            up: vec3("up")?,
            fov_y_deg: match fields.get("fov") {
                None => None,
                Some(v) => match v.as_f64() {
                    Some(f) if f > 0.0 && f < 180.0 => Some(f as f32),
                    _ => return Err(at(format!("\"fov\" must be degrees in (0, 180), got {v}"))),
                },
            },
        };
        let output = match fields.get("output") {
            None => default_output(main_output, n),
            Some(Value::String(s)) if !s.is_empty() => PathBuf::from(s),
            Some(v) => return Err(at(format!("\"output\" must be a file name, got {v}"))),
        };
        check_output_path(&output, IMAGE_EXTENSIONS)?;
        if output == main_output || views.iter().any(|v: &View| v.output == output) {
            return Err(at(format!(
                "{} is written by another view or the main image",
                output.display()
            )));
        }
        views.push(View { camera, output });
    }
    Ok(views)
}

fn three_numbers(v: &Value) -> Option<glam::Vec3> {
    let list = v.as_array().filter(|l| l.len() == 3)?;
    let mut out = [0.0f32; 3];
    for (o, x) in out.iter_mut().zip(list) {
        *o = x.as_f64().filter(|f| f.is_finite())? as f32;
    }
    Some(glam::Vec3::from(out))
}

/// `out.png` -> `out-view3.png`.
fn default_output(main_output: &Path, n: usize) -> PathBuf {
    let stem = main_output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "view".into());
    let ext = main_output
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_else(|| "png".into());
    main_output.with_file_name(format!("{stem}-view{n}.{ext}"))
}

/// Draws the lit mesh from every view at the main image's exposure and
/// writes each image; returns each output with its draw time in seconds
/// (raster and readback; the write excluded).
#[allow(clippy::too_many_arguments)]
pub(super) fn draw_views(
    job: &Job,
    scene: &Scene,
    device: &Arc<Device>,
    shown_mesh: &Mesh,
    shown: &[[f32; 3]],
    views: &[View],
    camera: &Camera,
    exposure: f32,
    gpu_times: &mut StageTimes,
) -> Result<Vec<(PathBuf, f64)>> {
    if views.is_empty() {
        return Ok(Vec::new());
    }
    // The mesh goes to the GPU once; each view is then one draw.
    let radiance = crate::render::radiance_of(shown.to_vec());
    let images = LitMeshImages::new(
        device,
        scene,
        shown_mesh,
        &radiance,
        job.size,
        job.wireframe,
    )?;
    let mut written = Vec::with_capacity(views.len());
    for view in views {
        let t = Instant::now();
        let image = images.draw(&view.camera.apply(*camera), gpu_times)?;
        let seconds = t.elapsed().as_secs_f64();
        save_image(&image, &view.output, Some(exposure))?;
        written.push((view.output.clone(), seconds));
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<View>> {
        parse_views(Path::new("cams.json"), text, Path::new("out.png"))
    }

    #[test]
    fn views_take_the_main_camera_where_they_say_nothing() {
        let views =
            parse(r#"{"views": [{"eye": [1, 2, 3]}, {"fov": 60, "output": "b.exr"}]}"#).unwrap();
        assert_eq!(views[0].camera.eye, Some(glam::Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(views[0].camera.look_at, None);
        assert_eq!(views[0].output, PathBuf::from("out-view1.png"));
        assert_eq!(views[1].camera.fov_y_deg, Some(60.0));
        assert_eq!(views[1].output, PathBuf::from("b.exr"));
        assert_eq!(parse(r#"[{"up": [0, 0, 1]}]"#).unwrap().len(), 1);
    }

    #[test]
    fn a_bad_view_is_named_with_what_is_wrong() {
        let message = |text: &str| parse(text).unwrap_err().to_string();
        assert!(message(r#"{"views": [{}, {"eye": [1, 2]}]}"#)
            .contains("cams.json: view 2: \"eye\" must be three finite numbers"));
        assert!(message(r#"[{"fov": 200}]"#).contains("view 1: \"fov\" must be degrees"));
        assert!(message(r#"[{"eye": [1, 2, 3], "target": [0, 0, 0]}]"#)
            .contains("unknown field \"target\""));
        assert!(message(r#"[{"output": "out.png"}]"#).contains("written by another view"));
        assert!(message(r#"[{"output": "a.txt"}]"#).contains("unknown file type"));
        assert!(message("[]").contains("lists no views"));
        assert!(message("{\"views\": [\n{]").contains("not JSON (line 2"));
    }
}
