//! Camera and light gestures in the viewport. They only compute new values; the editor turns them
//! into commands.

use crate::params::Light;
use crate::scene::Camera;
use eframe::egui;
use glam::{Vec2, Vec3};

/// How drags and keys move the camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CameraMode {
    /// Drag: orbit around the target; right/middle drag or Shift+drag: pan; wheel: dolly.
    #[default]
    Orbit,
    /// Drag: look around; W A S D: move, Q E: down/up (while the pointer is over the viewport);
    /// wheel: move forward/back.
    Fly,
}

/// Converts viewport input into camera changes.
#[derive(Debug, Clone)]
pub struct CameraController {
    pub mode: CameraMode,
    /// Degrees per point of drag.
    pub sensitivity: f32,
}

impl Default for CameraController {
    fn default() -> Self {
        CameraController { mode: CameraMode::Orbit, sensitivity: 0.3 }
    }
}

fn up_of(cam: &Camera) -> Vec3 {
    cam.up.try_normalize().unwrap_or(Vec3::Y)
}

/// Rotates `v` by `yaw` around `up` and `pitch` around the horizontal axis, keeping it away from
/// the poles (where the view's `up` would be parallel to the view direction).
fn rotate(v: Vec3, up: Vec3, yaw: f32, pitch: f32) -> Vec3 {
    let len = v.length();
    if len <= 0.0 {
        return v;
    }
    let d = v / len;
    let right = d.cross(up).try_normalize().unwrap_or(Vec3::X);
    let cur = d.dot(up).clamp(-1.0, 1.0).asin();
    let limit = 89.0f32.to_radians();
    let pitch = (cur + pitch).clamp(-limit, limit) - cur;
    let d = glam::Quat::from_axis_angle(right, pitch) * d;
    let d = glam::Quat::from_axis_angle(up, yaw) * d;
    d.normalize() * len
}

impl CameraController {
    /// Applies the pointer and keyboard input of this frame over the viewport; returns the new
    /// camera when it changed. `radius` is the scene's size, for speeds; `height_px` the viewport
    /// height in points (pans follow the pointer).
    pub fn handle(
        &self,
        ui: &egui::Ui,
        response: &egui::Response,
        cam: &Camera,
        radius: f32,
        height_pts: f32,
    ) -> Option<Camera> {
        let mut c = *cam;
        let up = up_of(cam);
        let drag = response.drag_delta();
        let (primary, secondary, middle) = (
            response.dragged_by(egui::PointerButton::Primary),
            response.dragged_by(egui::PointerButton::Secondary),
            response.dragged_by(egui::PointerButton::Middle),
        );
        let shift = ui.input(|i| i.modifiers.shift);
        let scroll = if response.hovered() { ui.input(|i| i.smooth_scroll_delta.y) } else { 0.0 };
        let rad = |px: f32| (px * self.sensitivity).to_radians();
        let offset = c.eye - c.target;
        let dist = offset.length().max(1e-6);
        let fwd = (c.target - c.eye) / dist;
        let right = fwd.cross(up).try_normalize().unwrap_or(Vec3::X);
        let cam_up = right.cross(fwd);
        let pan = |c: &mut Camera, d: egui::Vec2| {
            // One point of drag moves the scene by one point at the target's depth.
            let per_pt = 2.0 * dist * (c.fov_y_deg.to_radians() * 0.5).tan() / height_pts.max(1.0);
            let t = (-right * d.x + cam_up * d.y) * per_pt;
            c.eye += t;
            c.target += t;
        };
        match self.mode {
            CameraMode::Orbit => {
                if (secondary || middle || (primary && shift)) && drag != egui::Vec2::ZERO {
                    pan(&mut c, drag);
                } else if primary && drag != egui::Vec2::ZERO {
                    c.eye = c.target + rotate(offset, up, -rad(drag.x), rad(drag.y));
                }
                if scroll != 0.0 {
                    let d = (dist * (-scroll * 0.002).exp()).clamp(radius * 1e-3 + c.near * 2.0, radius * 100.0 + 1.0);
                    c.eye = c.target + offset / dist * d;
                }
            }
            CameraMode::Fly => {
                if (secondary || middle) && drag != egui::Vec2::ZERO {
                    pan(&mut c, drag);
                } else if primary && drag != egui::Vec2::ZERO {
                    c.target = c.eye + rotate(c.target - c.eye, up, -rad(drag.x), -rad(drag.y));
                }
                let (dt, keys) = ui.input(|i| {
                    let k = |key| i.key_down(key) as i32 as f32;
                    (
                        i.stable_dt.min(0.1),
                        Vec3::new(
                            k(egui::Key::D) - k(egui::Key::A),
                            k(egui::Key::E) - k(egui::Key::Q),
                            k(egui::Key::W) - k(egui::Key::S),
                        ),
                    )
                });
                let wants_keys = response.hovered() && !ui.ctx().egui_wants_keyboard_input();
                let speed = radius.max(1e-3) * 0.6;
                let mut step = Vec3::ZERO;
                if wants_keys && keys != Vec3::ZERO {
                    step += (right * keys.x + up * keys.y + fwd * keys.z) * speed * dt;
                    ui.ctx().request_repaint();
                }
                if scroll != 0.0 {
                    step += fwd * scroll * speed * 0.004;
                }
                c.eye += step;
                c.target += step;
            }
        }
        // Keep everything in front of the far plane.
        let reach = (c.eye - c.target).length() + radius * 3.0;
        if c.far < reach {
            c.far = reach;
        }
        (c != *cam && c.validate().is_ok()).then_some(c)
    }
}

/// Projects a world point into the viewport (points, relative to `rect`); `None` behind the eye.
pub fn project(cam: &Camera, rect: egui::Rect, p: Vec3) -> Option<egui::Pos2> {
    let aspect = rect.width() / rect.height().max(1.0);
    let clip = cam.view_proj(aspect) * p.extend(1.0);
    if clip.w <= 1e-9 {
        return None;
    }
    let ndc = Vec2::new(clip.x / clip.w, clip.y / clip.w);
    Some(egui::pos2(rect.left() + (ndc.x + 1.0) * 0.5 * rect.width(), rect.top() + (1.0 - ndc.y) * 0.5 * rect.height()))
}

/// Where the light's handle is drawn: the point light itself, or for a directional light the point
/// where its direction meets the sky (eye + direction), when in front of the camera.
pub fn light_handle(cam: &Camera, rect: egui::Rect, light: &Light) -> Option<egui::Pos2> {
    match *light {
        Light::Point { position, .. } => project(cam, rect, position),
        Light::Directional { direction, .. } => {
            let far = (cam.target - cam.eye).length().max(1e-3) * 10.0;
            project(cam, rect, cam.eye + direction.normalize_or(Vec3::Y) * far)
        }
    }
}

/// Moves the light by a pointer drag of `delta` points: a point light moves parallel to the
/// image plane at its own depth (it stays under the pointer); a directional light turns.
pub fn drag_light(cam: &Camera, light: &Light, delta: egui::Vec2, height_pts: f32) -> Light {
    let up = up_of(cam);
    let fwd = (cam.target - cam.eye).normalize_or(Vec3::NEG_Z);
    let right = fwd.cross(up).try_normalize().unwrap_or(Vec3::X);
    let cam_up = right.cross(fwd);
    match *light {
        Light::Point { position, intensity, radius } => {
            let depth = (position - cam.eye).dot(fwd).max(cam.near);
            let per_pt = 2.0 * depth * (cam.fov_y_deg.to_radians() * 0.5).tan() / height_pts.max(1.0);
            let p = position + (right * delta.x - cam_up * delta.y) * per_pt;
            Light::Point { position: p, intensity, radius }
        }
        Light::Directional { direction, irradiance } => {
            // One point of drag turns the light by as much as it moves on screen at the sky.
            let per_pt = 2.0 * (cam.fov_y_deg.to_radians() * 0.5).tan() / height_pts.max(1.0);
            let d = direction.normalize_or(Vec3::Y);
            let moved = (d + (right * delta.x - cam_up * delta.y) * per_pt).normalize_or(d);
            Light::Directional { direction: moved, irradiance }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_rotation_keeps_distance_and_avoids_the_pole() {
        let v = Vec3::new(0.0, 1.0, 5.0);
        let r = rotate(v, Vec3::Y, 0.3, 3.0);
        assert!((r.length() - v.length()).abs() < 1e-4);
        assert!(r.normalize().dot(Vec3::Y) < 0.9999);
    }

    #[test]
    fn dragged_point_light_follows_the_pointer() {
        let cam = Camera::default();
        let rect = egui::Rect::from_min_size(egui::pos2(10.0, 20.0), egui::vec2(400.0, 300.0));
        let light = Light::Point { position: Vec3::new(0.5, 0.5, 0.0), intensity: Vec3::ONE, radius: 0.0 };
        let before = light_handle(&cam, rect, &light).unwrap();
        let moved = drag_light(&cam, &light, egui::vec2(15.0, -10.0), rect.height());
        let after = light_handle(&cam, rect, &moved).unwrap();
        let d = after - before;
        assert!((d.x - 15.0).abs() < 0.5 && (d.y + 10.0).abs() < 0.5, "{d:?}");
    }
}
