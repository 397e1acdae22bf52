//! The pinhole camera of docs/scene-format.md: `from`, `to`, `up`, vertical field of view.

use glam::{DVec3, Vec3};

/// A pinhole camera. Build it with [`Camera::look_at`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, in f64: a scene's camera holds it in world space as the file gives it; the
    /// render sees the camera from the prepared frame's origin ([`Camera::seen_from`]), where
    /// its rays start, rounded to f32.
    pub origin: DVec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit vector to the image's right: `normalize(forward × up)`.
    pub right: Vec3,
    /// Unit vector to the image's top: `right × forward`.
    pub up: Vec3,
    /// `tan(fov / 2)` of the vertical field of view.
    pub tan_half_fov: f32,
}

/// Why a camera cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// `from` and `to` are the same point.
    NoDirection,
    /// `up` is zero or parallel to the viewing direction.
    UpParallel,
    /// The field of view is not strictly between 0 and 180 degrees.
    BadFov,
}

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CameraError::NoDirection => "`from` and `to` must be different points",
            CameraError::UpParallel => "`up` must be non-zero and not parallel to the viewing direction",
            CameraError::BadFov => "`fov` must be strictly between 0 and 180 degrees",
        })
    }
}

impl Camera {
    /// The camera at `from` looking at `to`, with `up` and a vertical field of view in degrees.
    /// The viewing direction is `to - from` taken in f64, then rounded to f32 once: it stays
    /// exact however far from the origin the two points are.
    pub fn look_at(from: DVec3, to: DVec3, up: Vec3, fov_deg: f32) -> Result<Camera, CameraError> {
        let forward = (to - from).as_vec3().try_normalize().ok_or(CameraError::NoDirection)?;
        let right = forward.cross(up).try_normalize().ok_or(CameraError::UpParallel)?;
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(CameraError::BadFov);
        }
        Ok(Camera {
            origin: from,
            forward,
            right,
            up: right.cross(forward),
            tan_half_fov: libm::tanf(fov_deg.to_radians() * 0.5),
        })
    }

    /// The same camera with its position measured from `origin` (in f64): the camera a frame
    /// whose origin is the world point `origin` renders with.
    #[inline]
    pub fn seen_from(&self, origin: DVec3) -> Camera {
        Camera { origin: self.origin - origin, ..*self }
    }

    /// The unit direction through image point `(px, py)` in pixels (`(0, 0)` is the top-left
    /// corner of the image; a pixel's centre is at `i + 0.5`).
    #[inline]
    pub fn direction(&self, px: f32, py: f32, width: u32, height: u32) -> Vec3 {
        let (w, h) = (width as f32, height as f32);
        let x = (2.0 * px / w - 1.0) * self.tan_half_fov * w / h;
        let y = (1.0 - 2.0 * py / h) * self.tan_half_fov;
        // forward is unit and orthogonal to right/up, so the sum is never zero.
        (self.forward + x * self.right + y * self.up).normalize()
    }

    /// [`Camera::direction`] through eight image points at once (`px[k]`, `py[k]`), axis by
    /// axis: the same operations in the same order, so the same bits lane by lane.
    #[inline]
    pub fn directions(&self, px: [f32; 8], py: [f32; 8], width: u32, height: u32) -> [[f32; 8]; 3] {
        use wide::f32x8;
        let (w, h) = (f32x8::splat(width as f32), f32x8::splat(height as f32));
        let (two, one, tan) = (f32x8::splat(2.0), f32x8::ONE, f32x8::splat(self.tan_half_fov));
        let x = (two * f32x8::new(px) / w - one) * tan * w / h;
        let y = (one - two * f32x8::new(py) / h) * tan;
        let v: [f32x8; 3] = std::array::from_fn(|a| {
            f32x8::splat(self.forward[a]) + x * f32x8::splat(self.right[a]) + y * f32x8::splat(self.up[a])
        });
        // `normalize`: times the reciprocal of the length.
        let rcp = one / (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| (c * rcp).to_array())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_directions_at_once_have_the_bits_of_each_alone() {
        // An oblique camera (every axis of every direction is a sum of three terms) and a
        // wide image, so the order of the sums and the aspect ratio both show.
        let cam =
            Camera::look_at(DVec3::new(3.0, 2.5, -7.0), DVec3::new(-1.0, 0.3, 2.0), Vec3::new(0.1, 1.0, 0.2), 53.0)
                .unwrap();
        let mut f = 0.41f32;
        for _ in 0..500 {
            let mut next = || {
                f = (f * 7.3 + 0.17).fract();
                f
            };
            let px: [f32; 8] = std::array::from_fn(|_| next() * 1920.0);
            let py: [f32; 8] = std::array::from_fn(|_| next() * 817.0);
            let eight = cam.directions(px, py, 1920, 817);
            for k in 0..8 {
                let one = cam.direction(px[k], py[k], 1920, 817);
                assert_eq!([eight[0][k], eight[1][k], eight[2][k]].map(f32::to_bits), one.to_array().map(f32::to_bits));
            }
        }
    }

    #[test]
    fn centre_pixel_looks_forward_and_row_zero_is_top() {
        let cam = Camera::look_at(DVec3::new(0.0, 0.0, -5.0), DVec3::ZERO, Vec3::Y, 40.0).unwrap();
        let d = cam.direction(50.0, 50.0, 100, 100);
        assert!((d - Vec3::Z).length() < 1e-6);
        assert!(cam.direction(50.0, 0.5, 100, 100).y > 0.0);
        // Right-handed: looking down +z with +y up, the image's right is -x.
        assert!(cam.direction(99.5, 50.0, 100, 100).x < 0.0);
        let top = cam.direction(50.0, 0.0, 100, 100);
        assert!((top.y.atan2(top.z).to_degrees() - 20.0).abs() < 1e-4);
    }

    #[test]
    fn a_camera_far_from_the_origin_looks_the_same_way_from_its_own_position() {
        // `to - from` in f64: in f32 at 10⁶ both points would be rounded to 1/16 first.
        let (from, to) = (DVec3::new(0.3, 2.5, -8.0), DVec3::new(-0.1, 0.8, 0.0));
        let near = Camera::look_at(from, to, Vec3::Y, 40.0).unwrap();
        let off = DVec3::new(1e6, -2e5, 7e5);
        let far = Camera::look_at(from + off, to + off, Vec3::Y, 40.0).unwrap();
        assert_eq!(far.origin, from + off);
        assert_eq!(far.seen_from(from + off), near.seen_from(from));
        assert_eq!(far.seen_from(from + off).origin, DVec3::ZERO);
    }

    #[test]
    fn degenerate_cameras_are_rejected() {
        assert_eq!(Camera::look_at(DVec3::ONE, DVec3::ONE, Vec3::Y, 40.0), Err(CameraError::NoDirection));
        assert_eq!(Camera::look_at(DVec3::ZERO, DVec3::Y, Vec3::Y, 40.0), Err(CameraError::UpParallel));
        assert_eq!(Camera::look_at(DVec3::ZERO, DVec3::Z, Vec3::Y, 180.0), Err(CameraError::BadFov));
    }
}
