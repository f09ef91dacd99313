//! [`Scene`]: what to draw, as layers of world-space geometry.

use rigfit_core::{Aabb, JointKind, Point3, Pose, Rig, Skeleton, Stroke, TriMesh};

use crate::color::{self, Color};

/// A skeleton as bones (parent to child segments) and joints.
#[derive(Clone, Debug, Default)]
pub struct SkeletonLayer {
    /// World positions of the joints drawn.
    pub joints: Vec<Point3>,
    /// Bones as `(parent, child)` indices into `joints`, each with its colour.
    pub bones: Vec<(usize, usize, Color)>,
}

/// Triangles shaded flat (brightness from the angle to the camera).
#[derive(Clone, Debug, Default)]
pub struct MeshLayer {
    pub vertices: Vec<Point3>,
    pub triangles: Vec<[u32; 3]>,
    pub color: Color,
}

/// Points drawn as dots; points flagged as outliers are drawn in `outlier_color`.
#[derive(Clone, Debug, Default)]
pub struct PointLayer {
    pub points: Vec<Point3>,
    /// Per point: `true` when the solver kept it. `None`: all are inliers.
    pub inliers: Option<Vec<bool>>,
    pub color: Color,
    pub outlier_color: Color,
}

/// An open polyline (a stroke).
#[derive(Clone, Debug, Default)]
pub struct PolylineLayer {
    pub points: Vec<Point3>,
    pub color: Color,
}

/// One thing to draw. Layers are drawn meshes first, then points, skeletons and polylines
/// (strokes) on top, whatever the order they were added in.
#[derive(Clone, Debug)]
pub enum Layer {
    Mesh(MeshLayer),
    Points(PointLayer),
    Polyline(PolylineLayer),
    Skeleton(SkeletonLayer),
}

/// A list of layers in one world space.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub layers: Vec<Layer>,
}

impl Scene {
    pub fn new() -> Self {
        Self::default()
    }

    /// The skeleton in `pose`, each chain of bones in its own colour (see
    /// [`color::chain_colors`]). Helper nodes (scene nodes above the skin) are left out.
    pub fn add_skeleton(&mut self, skeleton: &Skeleton, pose: &Pose) -> &mut Self {
        let colors = color::chain_colors(skeleton);
        self.add_skeleton_colored(skeleton, pose, &colors)
    }

    /// The skeleton in `pose` with a colour per joint: the bone from a joint's parent to the
    /// joint takes the joint's colour.
    pub fn add_skeleton_colored(
        &mut self,
        skeleton: &Skeleton,
        pose: &Pose,
        colors: &[Color],
    ) -> &mut Self {
        let world = skeleton.joint_positions(pose);
        let mut layer = SkeletonLayer::default();
        let mut drawn_index = vec![None; skeleton.len()];
        for (j, joint) in skeleton.joints().iter().enumerate() {
            if joint.kind == JointKind::Helper {
                continue;
            }
            drawn_index[j] = Some(layer.joints.len());
            layer.joints.push(world[j]);
            // The nearest drawn ancestor (helpers in between are skipped).
            let mut parent = joint.parent;
            while let Some(p) = parent {
                if let Some(pi) = drawn_index[p] {
                    let c = colors.get(j).copied().unwrap_or(color::INK);
                    layer.bones.push((pi, layer.joints.len() - 1, c));
                    break;
                }
                parent = skeleton.joint(p).parent;
            }
        }
        self.layers.push(Layer::Skeleton(layer));
        self
    }

    /// A rig in `pose`: its skinned meshes shaded flat and its skeleton on top.
    pub fn add_rig(&mut self, rig: &Rig, pose: &Pose) -> &mut Self {
        let world = rig.skeleton.world_matrices(pose);
        for mesh in &rig.meshes {
            if mesh.triangles.is_empty() {
                continue;
            }
            let (vertices, _) = mesh.skin(&world);
            self.layers.push(Layer::Mesh(MeshLayer {
                vertices,
                triangles: mesh.triangles.clone(),
                color: color::MESH,
            }));
        }
        self.add_skeleton(&rig.skeleton, pose)
    }

    /// A mesh shaded flat, or a point cloud as dots when it has no triangles.
    pub fn add_mesh(&mut self, mesh: &TriMesh) -> &mut Self {
        if mesh.is_point_cloud() {
            return self.add_points(&mesh.vertices, None);
        }
        self.layers.push(Layer::Mesh(MeshLayer {
            vertices: mesh.vertices.clone(),
            triangles: mesh.triangles.clone(),
            color: color::MESH,
        }));
        self
    }

    /// Points as dots; with `inliers`, the points flagged `false` are drawn as outliers.
    pub fn add_points(&mut self, points: &[Point3], inliers: Option<&[bool]>) -> &mut Self {
        self.layers.push(Layer::Points(PointLayer {
            points: points.to_vec(),
            inliers: inliers.map(<[bool]>::to_vec),
            color: color::INLIER,
            outlier_color: color::OUTLIER,
        }));
        self
    }

    /// One polyline.
    pub fn add_polyline(&mut self, points: &[Point3], color: Color) -> &mut Self {
        self.layers.push(Layer::Polyline(PolylineLayer {
            points: points.to_vec(),
            color,
        }));
        self
    }

    /// Strokes as polylines; stroke `i` in `colors[i]` (palette colours when `colors` is
    /// shorter).
    pub fn add_strokes(&mut self, strokes: &[Stroke], colors: &[Color]) -> &mut Self {
        for (i, stroke) in strokes.iter().enumerate() {
            let c = colors.get(i).copied().unwrap_or_else(|| color::palette(i));
            self.add_polyline(&stroke.points, c);
        }
        self
    }

    /// Every point of every layer.
    pub fn points(&self) -> impl Iterator<Item = &Point3> {
        self.layers.iter().flat_map(|layer| match layer {
            Layer::Mesh(m) => m.vertices.iter(),
            Layer::Points(p) => p.points.iter(),
            Layer::Polyline(p) => p.points.iter(),
            Layer::Skeleton(s) => s.joints.iter(),
        })
    }

    /// The box around every finite point of every layer (`None` when there is none).
    pub fn bounds(&self) -> Option<Aabb> {
        Aabb::from_points(self.points().filter(|p| p.iter().all(|c| c.is_finite())))
    }

    /// The number of points over all layers.
    pub fn point_count(&self) -> usize {
        self.points().count()
    }
}

/// Colours for strokes matched to bones: stroke `i` takes the colour of the middle bone of
/// `stroke_bones[i]` in `joint_colors` (as given by [`color::chain_colors`]), and
/// [`color::STRAY`] when it was matched to none.
pub fn stroke_colors(stroke_bones: &[Vec<usize>], joint_colors: &[Color]) -> Vec<Color> {
    stroke_bones
        .iter()
        .map(|bones| {
            bones
                .get(bones.len() / 2)
                .and_then(|&j| joint_colors.get(j).copied())
                .unwrap_or(color::STRAY)
        })
        .collect()
}
