//! Orthographic views of a Y-up world (the glTF and BVH convention) and the camera that
//! maps world points to pixels of one tile.

use rigfit_core::{Aabb, Point3, Vector3};

/// Where the camera looks from. The world is Y-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum View {
    /// From +Z: x to the right, y up.
    Front,
    /// From +X: -z to the right, y up.
    Side,
    /// From +Y, looking down: x to the right, -z up (the front, +z, at the bottom).
    Top,
}

impl View {
    /// The three views, front first.
    pub const ALL: [View; 3] = [View::Front, View::Side, View::Top];

    pub fn name(self) -> &'static str {
        match self {
            View::Front => "front",
            View::Side => "side",
            View::Top => "top",
        }
    }

    /// `(right, up, toward the camera)` coordinates of a world point.
    pub fn coordinates(self, p: &Point3) -> (f64, f64, f64) {
        match self {
            View::Front => (p.x, p.y, p.z),
            View::Side => (-p.z, p.y, p.x),
            View::Top => (p.x, -p.z, p.y),
        }
    }

    /// The unit vector from the scene toward the camera.
    pub fn toward_camera(self) -> Vector3 {
        match self {
            View::Front => Vector3::z(),
            View::Side => Vector3::x(),
            View::Top => Vector3::y(),
        }
    }
}

/// An orthographic camera for one tile of a picture: `pixel = origin + scale * (right, -up)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub view: View,
    /// Pixels per world unit.
    pub scale: f64,
    /// The pixel where the view coordinates `(0, 0)` land.
    pub origin: (f64, f64),
    /// The tile this camera draws into: `(x, y, width, height)` in pixels.
    pub tile: (u32, u32, u32, u32),
}

impl Camera {
    /// A camera that fits `bounds` inside the tile, leaving `margin` pixels on each side and
    /// `top_margin` above (for a label). Degenerate bounds (a point, a plane seen edge-on)
    /// get a sensible scale.
    pub fn fit(
        view: View,
        bounds: &Aabb,
        tile: (u32, u32, u32, u32),
        margin: f64,
        top_margin: f64,
    ) -> Self {
        let (mut u0, mut v0, mut u1, mut v1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for i in 0..8 {
            let corner = Point3::new(
                if i & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if i & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if i & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            );
            let (u, v, _) = view.coordinates(&corner);
            u0 = u0.min(u);
            u1 = u1.max(u);
            v0 = v0.min(v);
            v1 = v1.max(v);
        }
        let (x, y, w, h) = tile;
        let room_w = (w as f64 - 2.0 * margin).max(1.0);
        let room_h = (h as f64 - margin - top_margin).max(1.0);
        let fallback = bounds.diagonal().max(1e-9);
        let du = if u1 - u0 > 1e-9 * fallback {
            u1 - u0
        } else {
            fallback
        };
        let dv = if v1 - v0 > 1e-9 * fallback {
            v1 - v0
        } else {
            fallback
        };
        let scale = (room_w / du).min(room_h / dv);
        let center_px = (
            x as f64 + w as f64 / 2.0,
            y as f64 + top_margin + room_h / 2.0,
        );
        let (cu, cv) = ((u0 + u1) / 2.0, (v0 + v1) / 2.0);
        Self {
            view,
            scale,
            origin: (center_px.0 - cu * scale, center_px.1 + cv * scale),
            tile,
        }
    }

    /// The pixel `(x, y)` a world point lands on, and its depth toward the camera.
    pub fn project(&self, p: &Point3) -> (f64, f64, f64) {
        let (u, v, depth) = self.view.coordinates(p);
        (
            self.origin.0 + u * self.scale,
            self.origin.1 - v * self.scale,
            depth,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_puts_the_box_inside_the_tile() {
        let b = Aabb {
            min: Point3::new(-1.0, 0.0, -0.5),
            max: Point3::new(1.0, 2.0, 0.5),
        };
        for view in View::ALL {
            let cam = Camera::fit(view, &b, (100, 50, 200, 300), 10.0, 20.0);
            for p in [b.min, b.max, b.center()] {
                let (x, y, _) = cam.project(&p);
                assert!((110.0 - 1e-6..=290.0 + 1e-6).contains(&x), "{view:?} x {x}");
                assert!((70.0 - 1e-6..=340.0 + 1e-6).contains(&y), "{view:?} y {y}");
            }
        }
        // Y is up on the screen in the front view.
        let cam = Camera::fit(View::Front, &b, (0, 0, 200, 200), 0.0, 0.0);
        assert!(cam.project(&b.max).1 < cam.project(&b.min).1);
    }
}
