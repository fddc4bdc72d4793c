//! One hemicube's form factors read back, without shooting: F(point ->
//! every element) at a frame (tests and benchmarks judge the hemicube by
//! it).

use super::{FaceDraws, Shooter, ShootingEngine, Submission, FF_FIXED_ONE};
use crate::error::Result;

impl ShootingEngine {
    /// Form factors F(point -> element) from the finest hemicube at the
    /// given frame, for every element (no shooting).
    pub fn form_factors(&mut self, face_view_proj: &[glam::Mat4; 5]) -> Result<Vec<f64>> {
        self.ensure_idle("a form-factor row")?;
        let finest = self.hemicubes[0].0.res;
        self.write_params(
            0,
            0,
            &Shooter {
                faces: *face_view_proj,
                area: 0.0,
                ranks: (u32::MAX, u32::MAX),
                resolution: finest,
                region: None,
            },
        )?;
        let draws = self.cull_faces(0, &[*face_view_proj])?;
        self.record_form_factors(draws[0])?;
        self.submit_and_wait(Submission::FormFactors)?;
        let fixed: Vec<u32> = self.frames[0].readback.read(self.element_count as usize)?;
        Ok(fixed.into_iter().map(|f| f as f64 / FF_FIXED_ONE).collect())
    }

    fn record_form_factors(&mut self, draws: FaceDraws) -> Result<()> {
        let cmd = self.ff_cmds.begin()?;
        let mut profiler = self.ff_profiler.take();
        if let Some(p) = profiler.as_mut() {
            p.begin(cmd);
            p.set_submission(|| ("form-factor row".into(), serde_json::json!({})));
        }
        let frame = &self.frames[0];
        let indices = frame.indices.as_ref().map(|b| b.raw());
        let finest = &self.hemicubes[0].0;
        self.record_hemicube(cmd, &mut profiler, 0, (draws, indices), finest);
        if let Some(p) = profiler.as_mut() {
            p.begin_pass(cmd, "readback");
        }
        self.record_copies_to_host(
            cmd,
            &[(self.ff.raw(), 4 * self.element_count as u64, 0)],
            frame.readback.raw(),
        );
        if let Some(p) = profiler.as_mut() {
            p.end_pass(cmd);
        }
        self.ff_profiler = profiler;
        self.ff_cmds.end()
    }
}
