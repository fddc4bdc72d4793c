//! Projection matrices shared by the hemicube and the final render.
//!
//! Conventions: view space looks down -z (glam's `look_to_rh`); clip space is
//! Vulkan's, with y flipped so that the image's up is the view's up; depth is
//! reverse-Z with an infinite far plane (1 at `near`, 0 at infinity), which
//! keeps precision where radiosity needs it, close to the eye.

use glam::{Mat4, Vec4};

/// An off-centre frustum: at unit distance the image spans x in
/// [left, right] and y in [bottom, top].
pub fn frustum(left: f32, right: f32, bottom: f32, top: f32, near: f32) -> Mat4 {
    let w = right - left;
    let h = top - bottom;
    // Rows: x' = (2x + (r+l)z)/w, y' = -(2y + (t+b)z)/h, z' = near, w' = -z.
    Mat4::from_cols(
        Vec4::new(2.0 / w, 0.0, 0.0, 0.0),
        Vec4::new(0.0, -2.0 / h, 0.0, 0.0),
        Vec4::new((right + left) / w, -(top + bottom) / h, 0.0, -1.0),
        Vec4::new(0.0, 0.0, near, 0.0),
    )
}

/// A symmetric perspective projection with vertical field of view `fov_y`
/// (radians) and `aspect` = width / height.
pub fn perspective(fov_y: f32, aspect: f32, near: f32) -> Mat4 {
    let t = (fov_y * 0.5).tan();
    let r = t * aspect;
    frustum(-r, r, -t, t, near)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn project(m: Mat4, p: Vec3) -> Vec3 {
        let c = m * p.extend(1.0);
        c.truncate() / c.w
    }

    #[test]
    fn frustum_maps_corners_and_depth() {
        let m = frustum(-1.0, 1.0, 0.0, 1.0, 0.01);
        // Top-left of the window at distance 2 -> NDC (-1, -1) (Vulkan: y down).
        let p = project(m, Vec3::new(-2.0, 2.0, -2.0));
        assert!((p.x + 1.0).abs() < 1e-6 && (p.y + 1.0).abs() < 1e-6);
        // Bottom edge (y = 0) -> NDC y = +1.
        let p = project(m, Vec3::new(0.0, 0.0, -3.0));
        assert!((p.y - 1.0).abs() < 1e-6 && p.x.abs() < 1e-6);
        // Reverse-Z: near -> 1, far -> towards 0.
        assert!((project(m, Vec3::new(0.0, 0.5, -0.01)).z - 1.0).abs() < 1e-5);
        assert!(project(m, Vec3::new(0.0, 0.5, -1000.0)).z < 1e-4);
    }
}
