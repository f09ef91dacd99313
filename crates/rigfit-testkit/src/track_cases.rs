//! Ground-truth tracking sequences from real rigs: pose the rig at each frame (its own
//! animation, or a scripted motion), skin its mesh (or, for a bare skeleton, the model's
//! ellipsoids), sample points uniformly by area, keep those a virtual camera sees (a depth
//! buffer of the surface from one or two fixed viewpoints), add Gaussian noise, and add
//! outliers: uniform in an enlarged box and on a floor patch. Used by tests and benches.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use rigfit_core::geometry::{Aabb, TriMesh};
use rigfit_core::kinematics::ForwardKinematics;
use rigfit_core::math::{Point3, Quat, Vector3};
use rigfit_core::rig::Rig;
use rigfit_core::skeleton::Pose;
use rigfit_core::track::parts::PartModel;
use rigfit_core::track::texture::sample_triangles;

/// How to draw a sequence.
#[derive(Clone, Debug)]
pub struct SequenceOptions {
    /// Points per frame, outliers included.
    pub points: usize,
    /// Virtual cameras (1 or 2), fixed for the sequence.
    pub cameras: usize,
    /// Gaussian noise per coordinate, as a fraction of the height.
    pub noise: f64,
    /// Fraction of each frame's points that are outliers.
    pub outliers: f64,
    /// Fraction of the outliers on a floor patch (the rest uniform in an enlarged box).
    pub floor_share: f64,
    pub seed: u64,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        Self {
            points: 2000,
            cameras: 2,
            noise: 0.01,
            outliers: 0.25,
            floor_share: 0.4,
            seed: 1,
        }
    }
}

/// One generated frame.
#[derive(Clone, Debug)]
pub struct SequenceFrame {
    pub points: Vec<Point3>,
    /// Which points are outliers.
    pub outlier: Vec<bool>,
    /// The pose the points were drawn from.
    pub truth: Pose,
}

/// `frames` poses of a rig's animation `clip`, `1 / fps` seconds apart from `offset`
/// seconds after its start, wrapping around at its end (clips such as runs loop).
pub fn clip_poses(rig: &Rig, clip: usize, frames: usize, fps: f64, offset: f64) -> Vec<Pose> {
    let Some(animation) = rig.animations.get(clip) else {
        return vec![rig.pose.clone(); frames];
    };
    let (start, duration) = (animation.start(), animation.duration());
    (0..frames)
        .map(|f| {
            let mut t = offset + f as f64 / fps;
            if duration > 0.0 {
                t %= duration;
            }
            animation.sample(&rig.pose, start + t)
        })
        .collect()
}

/// A scripted hand motion for a WebXR-style hand rig: the fingers curl and open in turn
/// (about each phalanx's own x axis, toward the palm), the thumb folds in, and the whole
/// hand turns and travels.
pub fn hand_motion(rig: &Rig, frames: usize) -> Vec<Pose> {
    let skeleton = &rig.skeleton;
    let root = skeleton.skin_root();
    let height = rig.height();
    let fingers = [
        "index-finger",
        "middle-finger",
        "ring-finger",
        "pinky-finger",
    ];
    (0..frames)
        .map(|f| {
            let t = f as f64 / frames.max(1) as f64;
            let mut pose = rig.pose.clone();
            for (k, finger) in fingers.iter().enumerate() {
                let phase = t - 0.1 * k as f64;
                let curl = 0.5 - 0.5 * (std::f64::consts::TAU * phase).cos();
                for (part, scale) in [
                    ("phalanx-proximal", 1.1),
                    ("phalanx-intermediate", 1.2),
                    ("phalanx-distal", 0.8),
                ] {
                    if let Some(j) = skeleton.find(&format!("{finger}-{part}")) {
                        let bend = Quat::from_scaled_axis(Vector3::new(-scale * curl, 0.0, 0.0));
                        pose.local[j].rotation *= bend;
                    }
                }
            }
            let thumb = 0.5 - 0.5 * (std::f64::consts::TAU * t).cos();
            for (part, scale) in [("phalanx-proximal", 0.5), ("phalanx-distal", 0.7)] {
                if let Some(j) = skeleton.find(&format!("thumb-{part}")) {
                    pose.local[j].rotation *=
                        Quat::from_scaled_axis(Vector3::new(-scale * thumb, 0.0, 0.0));
                }
            }
            if let Some(r) = root {
                let turn = 0.6 * (std::f64::consts::TAU * t).sin();
                pose.local[r].rotation =
                    Quat::from_scaled_axis(Vector3::new(0.0, turn, 0.2 * turn))
                        * pose.local[r].rotation;
                let angle = std::f64::consts::TAU * t;
                // Travel in a loop a third of the hand's size wide, in the parent's frame.
                let scale = pose.local[r].scale.x.abs().max(1e-9);
                pose.local[r].translation +=
                    Vector3::new(angle.cos() - 1.0, 0.5 * angle.sin(), 0.3 * angle.sin())
                        * (0.3 * height / scale);
            }
            pose
        })
        .collect()
}

/// The rig's surface in `pose`: its skinned meshes, or the triangulated ellipsoids of
/// `parts` for a bare skeleton.
pub fn surface_at(rig: &Rig, pose: &Pose, parts: &PartModel) -> TriMesh {
    let has_mesh = rig.meshes.iter().any(|m| !m.triangles.is_empty());
    if !has_mesh {
        let fk = ForwardKinematics::new(&rig.skeleton, pose);
        return parts.triangulate(&fk, 12, 16);
    }
    let world = rig.skeleton.world_matrices(pose);
    let mut mesh = TriMesh::default();
    for m in &rig.meshes {
        let base = mesh.vertices.len() as u32;
        mesh.vertices.extend(m.skin(&world).0);
        mesh.triangles
            .extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    mesh
}

/// A fixed pinhole camera and its depth buffer.
#[derive(Clone, Debug)]
struct Camera {
    eye: Point3,
    right: Vector3,
    up: Vector3,
    forward: Vector3,
    /// Half-width of the image in normalised coordinates (`x / z`).
    half: f64,
    size: usize,
    depth: Vec<f64>,
}

impl Camera {
    fn looking_at(target: &Point3, from: Vector3, distance: f64, half_extent: f64) -> Self {
        let forward = -from.normalize();
        let right = forward.cross(&Vector3::y()).normalize();
        let up = right.cross(&forward);
        let size = 400;
        Self {
            eye: target - forward * distance,
            right,
            up,
            forward,
            half: half_extent / distance,
            size,
            depth: vec![f64::INFINITY; size * size],
        }
    }

    /// Image coordinates (in pixels) and depth.
    fn project(&self, p: &Point3) -> Option<(f64, f64, f64)> {
        let v = p - self.eye;
        let z = v.dot(&self.forward);
        if z <= 1e-9 {
            return None;
        }
        let scale = self.size as f64 / (2.0 * self.half);
        let u = (v.dot(&self.right) / z + self.half) * scale;
        let w = (v.dot(&self.up) / z + self.half) * scale;
        Some((u, w, z))
    }

    /// Rasterises the triangles' depths.
    fn render(&mut self, mesh: &TriMesh) {
        self.depth.fill(f64::INFINITY);
        let n = self.size as i64;
        for t in &mesh.triangles {
            let Some([a, b, c]) = t
                .iter()
                .map(|&i| self.project(&mesh.vertices[i as usize]))
                .collect::<Option<Vec<_>>>()
                .and_then(|v| <[(f64, f64, f64); 3]>::try_from(v).ok())
            else {
                continue;
            };
            let area = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
            if area.abs() < 1e-12 {
                continue;
            }
            let x0 = a.0.min(b.0).min(c.0).floor().max(0.0) as i64;
            let x1 = (a.0.max(b.0).max(c.0).ceil() as i64).min(n - 1);
            let y0 = a.1.min(b.1).min(c.1).floor().max(0.0) as i64;
            let y1 = (a.1.max(b.1).max(c.1).ceil() as i64).min(n - 1);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let wa = ((b.0 - px) * (c.1 - py) - (c.0 - px) * (b.1 - py)) / area;
                    let wb = ((c.0 - px) * (a.1 - py) - (a.0 - px) * (c.1 - py)) / area;
                    let wc = 1.0 - wa - wb;
                    if wa < -1e-9 || wb < -1e-9 || wc < -1e-9 {
                        continue;
                    }
                    let z = wa * a.2 + wb * b.2 + wc * c.2;
                    let cell = &mut self.depth[y as usize * self.size + x as usize];
                    if z < *cell {
                        *cell = z;
                    }
                }
            }
        }
    }

    /// Whether `p` is in front of the surface seen through its pixel (within `tolerance`).
    fn sees(&self, p: &Point3, tolerance: f64) -> bool {
        let Some((u, w, z)) = self.project(p) else {
            return false;
        };
        let (x, y) = (u.floor() as i64, w.floor() as i64);
        let n = self.size as i64;
        if x < 0 || y < 0 || x >= n || y >= n {
            return false;
        }
        let nearest = self.depth[y as usize * self.size + x as usize];
        z <= nearest + tolerance
    }
}

/// Draws a sequence: for each pose, the rig's surface sampled as a depth camera would see
/// it, with noise and outliers. Cameras and floor are placed from the first frame.
pub fn make_sequence(
    rig: &Rig,
    parts: &PartModel,
    poses: &[Pose],
    options: &SequenceOptions,
) -> Vec<SequenceFrame> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(options.seed);
    let height = rig.height();
    let first = surface_at(rig, &poses[0], parts);
    let Some(bounds) = Aabb::from_points(&first.vertices) else {
        return Vec::new();
    };
    let center = bounds.center();
    let half_extent = 1.3 * bounds.extent().max();
    let distance = 3.0 * bounds.extent().max();
    let directions = [
        Vector3::new(0.6, 0.3, 1.0),
        Vector3::new(-0.9, 0.25, 0.6),
        Vector3::new(0.0, 0.4, -1.0),
    ];
    let mut cameras: Vec<Camera> = directions
        .iter()
        .take(options.cameras.clamp(1, directions.len()))
        .map(|d| Camera::looking_at(&center, *d, distance, half_extent))
        .collect();
    let floor_y = bounds.min.y;
    let noise = Normal::new(0.0, (options.noise * height).max(1e-300)).expect("valid deviation");
    let outliers = (options.points as f64 * options.outliers).round() as usize;
    let inliers = options.points.saturating_sub(outliers);
    poses
        .iter()
        .map(|pose| {
            let mesh = surface_at(rig, pose, parts);
            for camera in &mut cameras {
                camera.render(&mesh);
            }
            let tolerance = 0.01 * height;
            let candidates =
                sample_triangles(&mesh.vertices, &mesh.triangles, inliers * 4, &mut rng);
            let mut points: Vec<Point3> = candidates
                .into_iter()
                .map(|(p, _)| p)
                .filter(|p| cameras.iter().any(|c| c.sees(p, tolerance)))
                .take(inliers)
                .collect();
            for p in &mut points {
                *p += Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                );
            }
            let mut outlier = vec![false; points.len()];
            let frame_bounds = Aabb::from_points(&mesh.vertices).unwrap_or(bounds);
            let (c, e) = (frame_bounds.center(), frame_bounds.extent() * 1.5);
            let on_floor = (outliers as f64 * options.floor_share).round() as usize;
            for k in 0..outliers {
                let p = if k < on_floor {
                    Point3::new(
                        center.x + (rng.random::<f64>() - 0.5) * 1.5 * height,
                        floor_y + noise.sample(&mut rng),
                        center.z + (rng.random::<f64>() - 0.5) * 1.5 * height,
                    )
                } else {
                    c + Vector3::new(
                        (rng.random::<f64>() - 0.5) * e.x.max(0.2 * height),
                        (rng.random::<f64>() - 0.5) * e.y.max(0.2 * height),
                        (rng.random::<f64>() - 0.5) * e.z.max(0.2 * height),
                    )
                };
                points.push(p);
                outlier.push(true);
            }
            let mut order: Vec<usize> = (0..points.len()).collect();
            order.shuffle(&mut rng);
            SequenceFrame {
                points: order.iter().map(|&i| points[i]).collect(),
                outlier: order.iter().map(|&i| outlier[i]).collect(),
                truth: pose.clone(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rigfit_core::humanoid::humanoid;

    #[test]
    fn a_camera_sees_the_front_not_the_back() {
        let rig = humanoid();
        let parts = PartModel::fit_to_skin(&rig.skeleton, &rig.pose, &rig.meshes, rig.height());
        let options = SequenceOptions {
            cameras: 1,
            outliers: 0.0,
            noise: 0.0,
            ..SequenceOptions::default()
        };
        let frames = make_sequence(&rig, &parts, std::slice::from_ref(&rig.pose), &options);
        let points = &frames[0].points;
        assert_eq!(points.len(), 2000);
        // The camera looks from +z (and a little from the side): most points on the front half.
        let front = points.iter().filter(|p| p.z > -0.01).count();
        assert!(front as f64 > 0.85 * points.len() as f64, "{front}");
    }

    #[test]
    fn outliers_are_counted_and_flagged() {
        let rig = humanoid();
        let parts = PartModel::fit_to_skin(&rig.skeleton, &rig.pose, &rig.meshes, rig.height());
        let poses = clip_poses(&rig, 0, 3, 30.0, 0.0);
        let frames = make_sequence(&rig, &parts, &poses, &SequenceOptions::default());
        assert_eq!(frames.len(), 3);
        for f in &frames {
            assert_eq!(f.points.len(), 2000);
            assert_eq!(f.outlier.iter().filter(|&&o| o).count(), 500);
        }
    }
}
