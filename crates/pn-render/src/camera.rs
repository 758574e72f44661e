//! The pinhole camera of a render scene.
//!
//! Convention (shared with the Mitsuba export): looking from `position` at `target`, `up`
//! projected onto the image plane; pixel (px, py) has px to the right and py **down**; the
//! image plane lies at distance 1 with half-width tan(fov/2) (horizontal field of view,
//! Mitsuba's `fov_axis = "x"`) and half-height = half-width·height/width. The ray of pixel
//! (px, py) with offset (sx, sy) ∈ [0,1)² passes through image-plane point (px+sx, py+sy);
//! (0.5, 0.5) is the pixel centre.

use anyhow::ensure;

/// A pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up vector (projected; must not be parallel to the view direction).
    pub up: [f64; 3],
    /// Horizontal field of view in degrees, in (0, 180).
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
}

/// Largest accepted image side (bounds memory from a typo).
pub const MAX_IMAGE_SIDE: usize = 16384;

/// The camera's orthonormal frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    /// Unit view direction.
    pub forward: [f64; 3],
    /// Unit image-right direction.
    pub right: [f64; 3],
    /// Unit image-up direction.
    pub up: [f64; 3],
    /// tan(fov/2).
    pub half_width: f64,
    /// tan(fov/2)·height/width.
    pub half_height: f64,
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    a.map(|c| c / n)
}

impl Camera {
    /// Checks the camera: finite vectors, position ≠ target, up not parallel to the view
    /// direction, fov in (0, 180), image sides in 1..=[`MAX_IMAGE_SIDE`].
    pub fn validate(&self) -> anyhow::Result<()> {
        for (name, v) in [
            ("position", self.position),
            ("target", self.target),
            ("up", self.up),
        ] {
            ensure!(
                v.iter().all(|c| c.is_finite()),
                "camera {name} must be finite, got {v:?}"
            );
        }
        let f = sub(self.target, self.position);
        ensure!(
            norm(f) > 0.0,
            "camera target must differ from its position ({:?})",
            self.position
        );
        ensure!(norm(self.up) > 0.0, "camera up must not be the zero vector");
        let s = norm(cross(normalize(f), normalize(self.up)));
        ensure!(
            s > 1e-6,
            "camera up {:?} is parallel to the view direction {:?}: choose another up vector",
            self.up,
            f
        );
        ensure!(
            self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg < 180.0,
            "camera fov must lie in (0, 180) degrees, got {}",
            self.fov_deg
        );
        ensure!(
            (1..=MAX_IMAGE_SIDE).contains(&self.width)
                && (1..=MAX_IMAGE_SIDE).contains(&self.height),
            "image size must be between 1 and {MAX_IMAGE_SIDE} pixels per side, got {}×{}",
            self.width,
            self.height
        );
        Ok(())
    }

    /// The orthonormal frame (call [`Camera::validate`] first).
    pub fn frame(&self) -> CameraFrame {
        let forward = normalize(sub(self.target, self.position));
        let right = normalize(cross(forward, self.up));
        let up = cross(right, forward);
        let half_width = (self.fov_deg.to_radians() * 0.5).tan();
        CameraFrame {
            forward,
            right,
            up,
            half_width,
            half_height: half_width * self.height as f64 / self.width as f64,
        }
    }

    /// The turntable view at `angle` (radians): the position rotated about the axis through
    /// `target` parallel to `up` by `angle`, right-handed about `up` (counter-clockwise seen
    /// from the tip of `up`: Rodrigues' formula p' = t + v cos θ + (u × v) sin θ +
    /// u (u·v)(1 − cos θ), v = position − target, u = up/|up|); target, up, fov and image size
    /// unchanged. `pn render --turntable K` renders views θ_k = 2πk/K, k = 0..K (view 0 is
    /// this camera).
    pub fn orbit(&self, angle: f64) -> Camera {
        let u = normalize(self.up);
        let v = sub(self.position, self.target);
        let (s, c) = angle.sin_cos();
        let uxv = cross(u, v);
        let uv = dot(u, v);
        let position =
            [0, 1, 2].map(|d| self.target[d] + v[d] * c + uxv[d] * s + u[d] * uv * (1.0 - c));
        Camera {
            position,
            ..self.clone()
        }
    }

    /// Whether any part of the box `[min, max]` can appear in the image: false when the box
    /// lies entirely behind the camera or its projection misses the image rectangle
    /// (conservative: true when the box straddles the camera's plane or contains the camera).
    pub fn sees_box(&self, min: [f64; 3], max: [f64; 3]) -> bool {
        let f = self.frame();
        let corners: [[f64; 3]; 8] = std::array::from_fn(|c| {
            std::array::from_fn(|d| if c >> d & 1 == 1 { max[d] } else { min[d] })
        });
        let v = corners.map(|p| sub(p, self.position));
        let z = v.map(|v| dot(v, f.forward));
        if z.iter().all(|z| *z <= 0.0) {
            return false; // entirely behind the camera
        }
        if z.iter().any(|z| *z <= 0.0) {
            return true; // straddles the camera's plane (or contains the camera)
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (v, z) in v.iter().zip(z) {
            let xy = [
                dot(*v, f.right) / (z * f.half_width),
                dot(*v, f.up) / (z * f.half_height),
            ];
            for d in 0..2 {
                lo[d] = lo[d].min(xy[d]);
                hi[d] = hi[d].max(xy[d]);
            }
        }
        // The box is convex: its image is inside the hull of the projected corners.
        lo[0] <= 1.0 && hi[0] >= -1.0 && lo[1] <= 1.0 && hi[1] >= -1.0
    }

    /// Unit direction of the ray through image point (`x`, `y`) in pixel units (x right,
    /// y down; pixel (px, py) spans [px, px+1) × [py, py+1)).
    pub fn ray_dir(&self, frame: &CameraFrame, x: f64, y: f64) -> [f64; 3] {
        let sx = (2.0 * x / self.width as f64 - 1.0) * frame.half_width;
        let sy = (1.0 - 2.0 * y / self.height as f64) * frame.half_height;
        normalize([0, 1, 2].map(|d| frame.forward[d] + sx * frame.right[d] + sy * frame.up[d]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            position: [0.0, 0.0, 4.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_deg: 90.0,
            width: 4,
            height: 2,
        }
    }

    #[test]
    fn pixel_axes_are_right_and_down() {
        let c = cam();
        let f = c.frame();
        // Looking down −z with y up: right is +x.
        assert!((f.right[0] - 1.0).abs() < 1e-15);
        let centre = c.ray_dir(&f, 2.0, 1.0);
        assert!((centre[2] + 1.0).abs() < 1e-15);
        // Left image edge at 45° (fov 90°): direction (−1, 0, −1)/√2.
        let left = c.ray_dir(&f, 0.0, 1.0);
        assert!((left[0] + 0.5f64.sqrt()).abs() < 1e-15 && left[1].abs() < 1e-15);
        // Top edge: half-height = tan 45° · 2/4 = 0.5, +y.
        let top = c.ray_dir(&f, 2.0, 0.0);
        assert!((top[1] / -top[2] - 0.5).abs() < 1e-15);
    }

    #[test]
    fn orbit_is_right_handed_about_up_and_keeps_the_distance() {
        let c = cam(); // at +z looking at the origin, up +y
        let q = c.orbit(std::f64::consts::FRAC_PI_2);
        // A quarter turn about +y takes +z to +x.
        assert!((q.position[0] - 4.0).abs() < 1e-12 && q.position[2].abs() < 1e-12);
        let full = c.orbit(2.0 * std::f64::consts::PI);
        assert!((0..3).all(|d| (full.position[d] - c.position[d]).abs() < 1e-12));
        // About a target off the origin and an up with a component along the view.
        let mut c2 = cam();
        c2.target = [1.0, 2.0, 0.0];
        c2.up = [0.0, 1.0, 0.5];
        let q = c2.orbit(1.1);
        let r = |p: [f64; 3]| norm(sub(p, c2.target));
        assert!((r(q.position) - r(c2.position)).abs() < 1e-12);
        let u = normalize(c2.up);
        let along = |p: [f64; 3]| dot(sub(p, c2.target), u);
        assert!((along(q.position) - along(c2.position)).abs() < 1e-12);
    }

    #[test]
    fn boxes_out_of_view_are_detected() {
        let c = cam(); // at z = 4 looking down −z, fov 90°
        assert!(c.sees_box([-0.5; 3], [0.5; 3]));
        assert!(!c.sees_box([-0.5, -0.5, 5.0], [0.5, 0.5, 6.0])); // behind
        assert!(!c.sees_box([20.0, -0.5, -0.5], [21.0, 0.5, 0.5])); // far to the right
        assert!(c.sees_box([-1.0, -1.0, 3.0], [1.0, 1.0, 5.0])); // contains the camera
    }

    #[test]
    fn bad_cameras_are_refused() {
        let mut c = cam();
        c.up = [0.0, 0.0, 2.0];
        assert!(c.validate().unwrap_err().to_string().contains("parallel"));
        let mut c = cam();
        c.fov_deg = 180.0;
        assert!(c.validate().is_err());
        let mut c = cam();
        c.width = 0;
        assert!(c.validate().unwrap_err().to_string().contains("image size"));
    }
}
