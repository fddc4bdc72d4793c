//! The viewer's camera: look around (drag), orbit (right drag), fly (keys),
//! back to the scene's camera (R). Plain geometry, no window.

use glam::Vec3;

use crate::scene::Camera;

/// Degrees of the steepest look up or down: never straight along the up
/// axis, where the view would have no horizon to keep.
const MAX_PITCH_DEG: f32 = 89.0;
/// A scroll notch multiplies the speed by this.
const SPEED_STEP: f32 = 1.25;
/// Speed at the start: this share of the scene's extent per second.
const START_SPEED: f32 = 0.25;

/// Movement asked by the keys held, each -1, 0 or 1 (or a sum).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Motion {
    pub forward: f32,
    pub right: f32,
    pub up: f32,
}

impl Motion {
    pub fn is_still(&self) -> bool {
        *self == Motion::default()
    }
}

/// A camera that moves about a scene and can go back to where it began.
#[derive(Debug, Clone)]
pub struct Navigator {
    home: Camera,
    /// Unchanged since the start or the last reset: [`Self::camera`] is
    /// `home` exactly.
    at_home: bool,
    eye: Vec3,
    /// World up (the home camera's up) and the horizontal directions of
    /// yaw 0 and 90 degrees.
    up: Vec3,
    ahead: Vec3,
    side: Vec3,
    yaw: f32,
    pitch: f32,
    /// Distance from the eye to the point looked at (the orbit's centre).
    focus: f32,
    /// Scene units per second.
    pub speed: f32,
    home_speed: f32,
}

impl Navigator {
    /// Starts at `home` in a scene of size `extent` (its bounding diagonal).
    pub fn new(home: Camera, extent: f32) -> Self {
        let up = home.up.normalize_or(Vec3::Y);
        let to = home.look_at - home.eye;
        let focus = to.length().max(1e-6 * extent.max(1e-6));
        let forward = to.normalize_or(Vec3::NEG_Z);
        let flat = forward - up * forward.dot(up);
        let ahead = if flat.length_squared() > 1e-8 {
            flat.normalize()
        } else {
            up.any_orthonormal_vector()
        };
        let side = ahead.cross(up).normalize();
        let pitch = forward.dot(up).clamp(-1.0, 1.0).asin();
        let speed = START_SPEED * extent.max(1e-6);
        Navigator {
            home,
            at_home: true,
            eye: home.eye,
            up,
            ahead,
            side,
            yaw: 0.0,
            pitch,
            focus,
            speed,
            home_speed: speed,
        }
    }

    /// Where it looks along.
    pub fn forward(&self) -> Vec3 {
        let horizontal = self.ahead * self.yaw.cos() + self.side * self.yaw.sin();
        horizontal * self.pitch.cos() + self.up * self.pitch.sin()
    }

    /// The camera now.
    pub fn camera(&self) -> Camera {
        if self.at_home {
            return self.home;
        }
        Camera {
            eye: self.eye,
            look_at: self.eye + self.forward() * self.focus,
            up: self.up,
            fov_y_deg: self.home.fov_y_deg,
        }
    }

    fn turn(&mut self, yaw: f32, pitch: f32) {
        let limit = MAX_PITCH_DEG.to_radians();
        self.yaw = (self.yaw + yaw) % std::f32::consts::TAU;
        self.pitch = (self.pitch + pitch).clamp(-limit, limit);
        self.at_home = false;
    }

    /// Looks around from where it stands: a drag of (`dx`, `dy`) pixels in
    /// a view `height` pixels tall turns by as many degrees as the field of
    /// view spans there (what was under the pointer stays about under it).
    pub fn look(&mut self, dx: f32, dy: f32, height: f32) {
        let per_pixel = self.home.fov_y_deg.to_radians() / height.max(1.0);
        self.turn(dx * per_pixel, -dy * per_pixel);
    }

    /// Circles the point looked at: the view turns as [`Self::look`] turns
    /// it, and the eye moves so that the point stays in front.
    pub fn orbit(&mut self, dx: f32, dy: f32, height: f32) {
        let centre = self.eye + self.forward() * self.focus;
        let per_pixel = std::f32::consts::PI / height.max(1.0);
        self.turn(-dx * per_pixel, dy * per_pixel);
        self.eye = centre - self.forward() * self.focus;
    }

    /// Moves for `seconds` as `motion` asks: forward along the view, right
    /// across it, up along the world's up.
    pub fn step(&mut self, motion: Motion, seconds: f32) {
        if motion.is_still() || seconds <= 0.0 {
            return;
        }
        let forward = self.forward();
        let right = forward.cross(self.up).normalize_or(self.side);
        let direction = forward * motion.forward + right * motion.right + self.up * motion.up;
        self.eye += direction * self.speed * seconds;
        self.at_home = false;
    }

    /// Scroll `notches` (positive: faster).
    pub fn scroll(&mut self, notches: f32) {
        self.speed = (self.speed * SPEED_STEP.powf(notches))
            .clamp(self.home_speed * 1e-4, self.home_speed * 1e4);
    }

    /// Back to the scene's camera and the starting speed.
    pub fn reset(&mut self) {
        *self = Navigator::new(self.home, self.home_speed / START_SPEED);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn home() -> Camera {
        Camera {
            eye: Vec3::new(278.0, 273.0, -800.0),
            look_at: Vec3::new(278.0, 273.0, 0.0),
            up: Vec3::Y,
            fov_y_deg: 39.3,
        }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-3 * (1.0 + a.length().max(b.length()))
    }

    #[test]
    fn it_starts_at_the_scene_camera_and_resets_to_it() {
        let mut nav = Navigator::new(home(), 1000.0);
        assert_eq!(nav.camera(), home());
        assert!(close(nav.forward(), Vec3::Z));
        nav.look(40.0, -10.0, 600.0);
        nav.step(
            Motion {
                forward: 1.0,
                right: 1.0,
                up: 1.0,
            },
            0.5,
        );
        nav.scroll(3.0);
        assert_ne!(nav.camera(), home());
        nav.reset();
        assert_eq!(nav.camera(), home());
        assert_eq!(nav.speed, 250.0);
    }

    #[test]
    fn keys_move_along_the_view_across_it_and_up() {
        let mut nav = Navigator::new(home(), 1000.0);
        let speed = nav.speed;
        let start = nav.camera().eye;
        let forward = Motion {
            forward: 1.0,
            ..Motion::default()
        };
        nav.step(forward, 2.0);
        assert!(close(nav.camera().eye, start + Vec3::Z * 2.0 * speed));
        // Right of a view along +z with y up is -x.
        let right = Motion {
            right: 1.0,
            ..Motion::default()
        };
        nav.step(right, 1.0);
        assert!(close(
            nav.camera().eye,
            start + Vec3::Z * 2.0 * speed - Vec3::X * speed
        ));
        let up = Motion {
            up: -1.0,
            ..Motion::default()
        };
        let before = nav.camera().eye;
        nav.step(up, 1.0);
        assert!(close(nav.camera().eye, before - Vec3::Y * speed));
        // The view's direction does not change by moving.
        assert!(close(nav.forward(), Vec3::Z));
    }

    #[test]
    fn dragging_turns_the_view_and_never_past_straight_up() {
        let mut nav = Navigator::new(home(), 1000.0);
        // A drag to the right by the view's height turns right by the fov.
        nav.look(600.0, 0.0, 600.0);
        let f = nav.forward();
        let angle = f.dot(Vec3::Z).acos().to_degrees();
        assert!((angle - 39.3).abs() < 1e-2, "{angle}");
        assert!(f.x < 0.0, "turned right (towards -x): {f}");
        // Far up: stops short of the up axis; the camera stays valid.
        nav.look(0.0, -1e6, 600.0);
        let up_angle = nav.forward().dot(Vec3::Y).acos().to_degrees();
        assert!((up_angle - 1.0).abs() < 1e-2, "{up_angle}");
        assert!(nav.camera().look_at != nav.camera().eye);
    }

    #[test]
    fn orbiting_keeps_the_point_looked_at() {
        let mut nav = Navigator::new(home(), 1000.0);
        let centre = home().look_at;
        nav.orbit(150.0, 80.0, 600.0);
        let cam = nav.camera();
        assert!(close(cam.look_at, centre), "{:?}", cam.look_at);
        assert!(((cam.eye - centre).length() - 800.0).abs() < 1e-2);
        assert!(!close(cam.eye, home().eye));
    }

    #[test]
    fn scrolling_changes_the_speed_by_steps() {
        let mut nav = Navigator::new(home(), 1000.0);
        nav.scroll(1.0);
        assert!((nav.speed - 250.0 * 1.25).abs() < 1e-3);
        nav.scroll(-2.0);
        assert!((nav.speed - 250.0 / 1.25).abs() < 1e-3);
    }
}
