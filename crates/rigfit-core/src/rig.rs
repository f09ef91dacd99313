//! A rigged character: skeleton, its stored pose, skinned meshes and animations.

use crate::animation::{Animation, ChannelTarget};
use crate::geometry::{Aabb, TriMesh};
use crate::math::{Point3, Trs, Vector3};
use crate::skeleton::{JointDof, JointKind, JointTie, Pose, Skeleton};

/// A box whose y side is under this share of its z side is taken to be z-up.
const Z_UP_RATIO: f64 = 0.6;

/// An animated translation further than this share of the height from the joint's rest
/// translation moves the joint.
const TRANSLATION_TOLERANCE: f64 = 1e-4;

/// A translating joint is tied to another joint when, over the rest pose and its clips, its
/// origin strays at most this share of the height from one place in that joint's frame.
const TIE_TOLERANCE: f64 = 2e-3;

/// Each clip is sampled at this many evenly spaced times when looking for ties.
const TIE_SAMPLES: usize = 32;

/// The most (goal, joint, sample) comparisons the search for ties makes: a rig whose
/// candidate goals, joints and clips would need more (thousands of each, far beyond any
/// real rig: mrfixit needs 5,000) gets no ties rather than minutes of work.
const TIE_BUDGET: usize = 50_000_000;

/// The most joint transforms sampled from the clips that the search for ties (a world
/// matrix per joint and sample) or for clip places (a local transform per carrier and
/// sample) holds at once: about 250 MB of world matrices. mrfixit holds under 3,000.
const SAMPLED_TRANSFORMS_BUDGET: usize = 2_000_000;

/// At most this many clip places are noted per joint ([`Rig::note_clip_places`]), each
/// at least [`CLIP_PLACE_APART`] from the others and from rest, where a radian of turn
/// counts [`CLIP_PLACE_TURN`] of the height.
const CLIP_PLACES: usize = 6;
const CLIP_PLACE_APART: f64 = 0.05;
const CLIP_PLACE_TURN: f64 = 0.25;

/// A leaf joint gets a tip from its skin when the vertices it dominates lie to one side of
/// it: their centroid at least this share of their farthest distance from the joint.
const TIP_SIDEDNESS: f64 = 0.25;

/// ... and the tip is at least this share of the skin's size (its bounding box's largest
/// side at bind time) from the joint.
const TIP_MIN_LENGTH: f64 = 0.02;

use crate::skinning::SkinnedMesh;

/// Everything a rig file holds that rigfit works with.
#[derive(Clone, Debug)]
pub struct Rig {
    pub skeleton: Skeleton,
    /// The pose stored in the file (glTF node transforms; BVH frame 0).
    pub pose: Pose,
    pub meshes: Vec<SkinnedMesh>,
    pub animations: Vec<Animation>,
}

/// Whether a body whose bounding box has extent `extent` stands along z: its y side is
/// well under its z side and, with a skinned mesh (not `bare`), no longer than its x side.
pub fn z_is_up(extent: &Vector3, bare: bool) -> bool {
    extent.y < Z_UP_RATIO * extent.z && (bare || extent.y <= extent.x)
}

impl Rig {
    /// World points that describe the character's extent for `pose`: skinned mesh
    /// vertices when there is a mesh, otherwise joint positions.
    pub fn extent_points(&self, pose: &Pose) -> Vec<Point3> {
        let world = self.skeleton.world_matrices(pose);
        if self.meshes.iter().any(|m| !m.positions.is_empty()) {
            self.meshes.iter().flat_map(|m| m.skin(&world).0).collect()
        } else {
            self.skeleton
                .joints()
                .iter()
                .zip(&world)
                .filter(|(j, _)| j.kind != JointKind::Helper)
                .map(|(_, m)| Point3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]))
                .collect()
        }
    }

    /// The bounding box of the character in `pose`.
    pub fn bounds(&self, pose: &Pose) -> Option<Aabb> {
        Aabb::from_points(&self.extent_points(pose))
    }

    /// The character's height: the vertical extent of its bounding box in the stored pose.
    /// Vertical is y (the glTF and BVH up axis), unless the box is well under its z side
    /// along y (and, with a skinned mesh, y is its thinnest side): then the file is z-up
    /// (many mocap, robotics and DCC exports are) and z is vertical. The largest extent if
    /// the box is degenerate.
    pub fn height(&self) -> f64 {
        match self.bounds(&self.pose) {
            Some(b) => {
                let e = b.extent();
                // A skinned mesh's thinnest side is its depth; a bare skeleton's box may be
                // stretched by a root far from the body (a marker rig's origin).
                let bare = !self.meshes.iter().any(|m| !m.positions.is_empty());
                if z_is_up(&e, bare) {
                    e.z
                } else if e.y > 1e-9 {
                    e.y
                } else {
                    e.max()
                }
            }
            None => 0.0,
        }
    }

    /// Gives translation degrees of freedom ([`JointDof::Free`]) to every joint of the
    /// character (skin joints and the helpers linking them) whose animations move its
    /// translation (markers, hip nodes, BVH position channels that change): posing and
    /// tracking must move them as the file does. A translation the animations hold still
    /// (an exporter's constant offset from the rest pose, a BVH position channel that never
    /// changes) is not a motion: such a joint keeps its degrees of freedom. Returns how
    /// many joints were freed.
    pub fn free_translating_joints(&mut self) -> usize {
        let size = self.height().max(1e-12);
        // Per joint, the box of the translations its animations give it.
        let mut boxes: Vec<Option<(Vector3, Vector3)>> = vec![None; self.skeleton.len()];
        for animation in &self.animations {
            for channel in &animation.channels {
                if channel.target != ChannelTarget::Translation || channel.joint >= boxes.len() {
                    continue;
                }
                for v in &channel.values {
                    let t = Vector3::new(v[0], v[1], v[2]);
                    let b = boxes[channel.joint].get_or_insert((t, t));
                    *b = (b.0.inf(&t), b.1.sup(&t));
                }
            }
        }
        let translates: Vec<bool> = boxes
            .iter()
            .map(|b| b.is_some_and(|(lo, hi)| (hi - lo).norm() > TRANSLATION_TOLERANCE * size))
            .collect();
        let mut freed = 0;
        let linking = self.skeleton.linking_helpers();
        for (j, &moves) in translates.iter().enumerate() {
            let joint = self.skeleton.joint(j);
            // Helpers above the character or hanging off it (IK goals, sockets) stay fixed:
            // strokes never pull them. A helper linking skin joints (a hip node a clip drops
            // from the body) is part of the character and moves as the file moves it.
            let of_the_character = joint.kind != JointKind::Helper || linking[j];
            if moves && of_the_character && joint.dof != JointDof::Free {
                let limits = joint.limits;
                self.skeleton.set_dof(j, JointDof::Free, limits);
                freed += 1;
            }
        }
        freed
    }

    /// Ties each free joint that carries joints of its own and whose clips translate it (an
    /// IK goal with a hand below it) to the joint its clips keep it at: over the rest pose
    /// and every clip, its origin stays at one place in that joint's frame (within
    /// 0.2% of the height), the joint neither above nor below it. mrfixit's
    /// hands hang from IK goals that the clips move with the ends of its arms; nothing in
    /// the skeleton says so, and tracked without the tie the hands float free of the arms.
    /// Among joints that qualify, the nearest wins. Call after
    /// [`Rig::free_translating_joints`] (readers do). Returns how many joints were tied.
    pub fn tie_goals(&mut self) -> usize {
        let skeleton = &self.skeleton;
        let n = skeleton.len();
        let tolerance = TIE_TOLERANCE * self.height().max(1e-12);
        let goals: Vec<usize> = (0..n)
            .zip(self.translating_carriers())
            .filter_map(|(j, carries)| carries.then_some(j))
            .collect();
        if goals.is_empty() {
            return 0;
        }
        let samples = 1 + self.animations.len().saturating_mul(TIE_SAMPLES);
        if goals.len().saturating_mul(n).saturating_mul(samples) > TIE_BUDGET
            || n.saturating_mul(samples) > SAMPLED_TRANSFORMS_BUDGET
        {
            tracing::warn!(
                "{} free joints, {n} joints and {} clips: too many to look for IK goals' ties",
                goals.len(),
                self.animations.len()
            );
            return 0;
        }
        // The world transforms of the rest pose and of every clip's samples.
        let rest = skeleton.rest_pose();
        let mut worlds = vec![skeleton.world_matrices(&rest)];
        self.for_each_clip_sample(&rest, |pose| worlds.push(skeleton.world_matrices(pose)));
        let origin = crate::math::translation_part;
        let mut ties = Vec::new();
        for &goal in &goals {
            let mut best: Option<(f64, JointTie)> = None;
            for to in 0..n {
                if skeleton.is_ancestor_or_self(goal, to) || skeleton.is_ancestor_or_self(to, goal)
                {
                    continue;
                }
                // The goal's origin in `to`'s frame, sample by sample.
                let places: Vec<Vector3> = worlds
                    .iter()
                    .filter_map(|w| {
                        let inverse = w[to].try_inverse()?;
                        Some(
                            crate::math::transform_point(&inverse, &origin(&w[goal]).into()).coords,
                        )
                    })
                    .collect();
                if places.len() != worlds.len() {
                    continue;
                }
                let offset = places.iter().sum::<Vector3>() / places.len() as f64;
                // Measured in the world (the frame may scale).
                let strays = worlds.iter().zip(&places).any(|(w, p)| {
                    (crate::math::linear_part(&w[to]) * (p - offset)).norm() > tolerance
                });
                if strays {
                    continue;
                }
                let distance = (origin(&worlds[0][goal]) - origin(&worlds[0][to])).norm();
                if best.as_ref().is_none_or(|(d, _)| distance < *d) {
                    best = Some((distance, JointTie { to, offset }));
                }
            }
            // Two goals the clips move together are tied once (the later to the earlier).
            if let Some((_, tie)) = best
                && !ties
                    .iter()
                    .any(|&(g, t): &(usize, JointTie)| g == tie.to && t.to == goal)
            {
                ties.push((goal, tie));
            }
        }
        for &(goal, tie) in &ties {
            self.skeleton.set_tie(goal, Some(tie));
        }
        ties.len()
    }

    /// Notes, for each free joint below the root that carries joints, that the clips
    /// translate and that is tied to no other such joint (a hip node a sit clip drops to
    /// the floor with the legs under it), a few of the local transforms the clips give it,
    /// as far apart as they come ([`crate::skeleton::Joint::clip_places`]), and for each
    /// such joint tied to it (the other hip, which the clips keep at the same place) its
    /// transforms at the same clip times. Tracking's first-frame search tries the joints at
    /// each, since the fit's own steps from the rest pose do not carry a limb that far.
    /// Joints tied to any other joint (an IK goal at the end of an arm) get none: their tie
    /// places them. Call after [`Rig::tie_goals`] (readers do). Returns how many joints got
    /// places.
    pub fn note_clip_places(&mut self) -> usize {
        let skeleton = &self.skeleton;
        let n = skeleton.len();
        let size = self.height().max(1e-12);
        let carries = self.translating_carriers();
        // Each leader with the joints tied to it.
        let groups: Vec<(usize, Vec<usize>)> = (0..n)
            .filter(|&j| carries[j] && skeleton.joint(j).tie.is_none())
            .map(|j| {
                let tied = (0..n)
                    .filter(|&f| carries[f] && skeleton.joint(f).tie.is_some_and(|t| t.to == j))
                    .collect();
                (j, tied)
            })
            .collect();
        let samples = self.animations.len().saturating_mul(TIE_SAMPLES);
        if groups.is_empty() || samples == 0 || n.saturating_mul(samples) > TIE_BUDGET {
            return 0;
        }
        // Per sample, the local transforms of the grouped joints alone (in `joints` order).
        let joints: Vec<usize> = groups
            .iter()
            .flat_map(|(leader, tied)| std::iter::once(*leader).chain(tied.iter().copied()))
            .collect();
        if joints.len().saturating_mul(samples) > SAMPLED_TRANSFORMS_BUDGET {
            tracing::warn!(
                "{} translating limb carriers and {} clips: too many to note their clip places",
                joints.len(),
                self.animations.len()
            );
            return 0;
        }
        let rest = skeleton.rest_pose();
        let mut poses: Vec<Vec<Trs>> = Vec::with_capacity(samples);
        self.for_each_clip_sample(&rest, |pose| {
            poses.push(joints.iter().map(|&j| pose.local[j]).collect());
        });
        let column = |j: usize| joints.iter().position(|&k| k == j).unwrap_or(0);
        // Apart: the translations' distance in heights plus the turn between them.
        let apart = |a: &Trs, b: &Trs| {
            (a.translation - b.translation).norm() / size
                + CLIP_PLACE_TURN * a.rotation.angle_to(&b.rotation)
        };
        let mut noted = 0;
        for (leader, tied) in groups {
            let at = column(leader);
            // Farthest first, from the rest transform.
            let mut chosen: Vec<usize> = Vec::new();
            let mut nearest: Vec<f64> = poses
                .iter()
                .map(|p| apart(&p[at], &rest.local[leader]))
                .collect();
            while chosen.len() < CLIP_PLACES {
                let Some((k, &d)) = nearest.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))
                else {
                    break;
                };
                if d < CLIP_PLACE_APART {
                    break;
                }
                chosen.push(k);
                let place = poses[k][at];
                for (m, p) in nearest.iter_mut().zip(&poses) {
                    *m = m.min(apart(&p[at], &place));
                }
            }
            if chosen.is_empty() {
                continue;
            }
            for j in std::iter::once(leader).chain(tied) {
                let places = chosen.iter().map(|&k| poses[k][column(j)]).collect();
                self.skeleton.set_clip_places(j, places);
                noted += 1;
            }
        }
        noted
    }

    /// For every joint, whether it is free, below a parent, carries joints and is
    /// translated by a clip: the IK goals [`Rig::tie_goals`] looks for and the limb
    /// carriers [`Rig::note_clip_places`] samples.
    fn translating_carriers(&self) -> Vec<bool> {
        let skeleton = &self.skeleton;
        let n = skeleton.len();
        let mut translated = vec![false; n];
        for channel in self.animations.iter().flat_map(|a| &a.channels) {
            if channel.target == ChannelTarget::Translation && channel.joint < n {
                translated[channel.joint] = true;
            }
        }
        (0..n)
            .map(|j| {
                let joint = skeleton.joint(j);
                joint.dof == JointDof::Free
                    && joint.parent.is_some()
                    && translated[j]
                    && !skeleton.children(j).is_empty()
            })
            .collect()
    }

    /// Calls `f` with each clip sampled from `base` at [`TIE_SAMPLES`] evenly spaced times.
    fn for_each_clip_sample(&self, base: &Pose, mut f: impl FnMut(&Pose)) {
        for clip in &self.animations {
            let (start, duration) = (clip.start(), clip.duration());
            for k in 0..TIE_SAMPLES {
                let t = start + duration * k as f64 / (TIE_SAMPLES - 1) as f64;
                f(&clip.sample(base, t));
            }
        }
    }

    /// Gives every leaf skin joint whose skin hangs to one side of it (a limb box of a
    /// game character, a head, a tail tip) an end site at the far end of that skin, as a
    /// BVH `End Site` gives the last bone of a chain its length: without one the leaf
    /// bone has no extent to draw a stroke along or to fit. The tip lies along the
    /// centroid of the vertices the joint dominates (largest weight), as far as the
    /// farthest of them along that direction (bind pose). Tips are named `NAME_end`, of
    /// kind [`JointKind::SkinTip`] (fixed, never reported), and appended after the
    /// existing joints (indices unchanged). Readers do not call it (a file's joints are
    /// what the Python package and the server expose); the posing command and the corpus
    /// do. Returns how many were added.
    pub fn tip_skinned_leaves(&mut self) -> usize {
        // The size of the skin as modelled (bind pose), not as the stored pose bends it.
        let bind_points: Vec<Point3> = self
            .meshes
            .iter()
            .flat_map(|m| m.positions.iter().copied())
            .collect();
        let size = Aabb::from_points(&bind_points).map_or(0.0, |b| b.extent().max());
        let joints = self.skeleton.len();
        // Per joint: the vertices it dominates, in its bind frame.
        let mut dominated: Vec<Vec<Point3>> = vec![Vec::new(); joints];
        for mesh in &self.meshes {
            for (v, position) in mesh.positions.iter().enumerate() {
                let (Some(influences), Some(weights)) = (mesh.joints.get(v), mesh.weights.get(v))
                else {
                    continue;
                };
                let best = (0..4).max_by(|&a, &b| weights[a].total_cmp(&weights[b]));
                let Some(k) = best.filter(|&k| weights[k] > 0.0) else {
                    continue;
                };
                let j = influences[k] as usize;
                if j < joints {
                    let bind = mesh.inverse_bind.get(j).copied().unwrap_or_default();
                    dominated[j].push(crate::math::transform_point(&bind, position));
                }
            }
        }
        // Where each joint was at bind time (the frame its skin was modelled in; a file's
        // stored pose may be any pose), from the inverse bind matrices.
        let mut bind_world: Vec<Option<crate::math::Matrix4>> = vec![None; joints];
        for mesh in &self.meshes {
            for (j, inverse) in mesh.inverse_bind.iter().enumerate().take(joints) {
                if bind_world[j].is_none() && *inverse != crate::math::Matrix4::identity() {
                    bind_world[j] = inverse.try_inverse();
                }
            }
        }
        let at = |m: &crate::math::Matrix4| Point3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
        let mut added = Vec::new();
        for (j, points) in dominated.iter().enumerate() {
            let joint = self.skeleton.joint(j);
            if joint.kind != JointKind::Skin || !self.skeleton.children(j).is_empty() {
                continue;
            }
            let Some(tip) = skin_tip(points, TIP_MIN_LENGTH * size) else {
                continue;
            };
            // A flat hierarchy (every joint of a hand a child of the wrist) makes leaves of
            // joints whose bone runs to another joint: no tip where one would run into a
            // joint that is not its ancestor.
            let Some(frame) = bind_world[j] else {
                continue;
            };
            let (from, to) = (
                at(&frame),
                crate::math::transform_point(&frame, &Point3::from(tip)),
            );
            let runs_into_joint = (0..joints).any(|k| {
                k != j
                    && !self.skeleton.is_ancestor_or_self(k, j)
                    && bind_world[k].is_some_and(|m| near_segment(&at(&m), &from, &to))
            });
            if !runs_into_joint {
                added.push((j, tip));
            }
        }
        if added.is_empty() {
            return 0;
        }
        let mut all = self.skeleton.joints().to_vec();
        for &(j, tip) in &added {
            let base = format!("{}_end", all[j].name);
            let mut name = base.clone();
            let mut n = 1;
            while all.iter().any(|other| other.name == name) {
                n += 1;
                name = format!("{base}{n}");
            }
            let mut end =
                crate::skeleton::Joint::new(name, Some(j), crate::math::Trs::from_translation(tip));
            end.kind = JointKind::SkinTip;
            end.dof = JointDof::Fixed;
            self.pose.local.push(end.rest);
            all.push(end);
        }
        self.skeleton = Skeleton::new(all).expect("end sites appended after their parents");
        for mesh in &mut self.meshes {
            mesh.inverse_bind
                .resize(self.skeleton.len(), crate::math::Matrix4::identity());
        }
        added.len()
    }

    /// Indices of joints that are reported to users (skin joints and end sites; not helpers
    /// or tips found from the skin, which are not in the file).
    pub fn reported_joints(&self) -> impl Iterator<Item = usize> + '_ {
        self.skeleton
            .joints()
            .iter()
            .enumerate()
            .filter(|(_, j)| !matches!(j.kind, JointKind::Helper | JointKind::SkinTip))
            .map(|(i, _)| i)
    }

    /// Every skinned mesh in `pose`, concatenated, with area-weighted face normals: the
    /// surface a `.glb` reference gives `surface` (`rigfit_formats::mesh_file::read_surface`,
    /// Python's `Rig.mesh`).
    pub fn skinned_surface(&self, pose: &Pose) -> TriMesh {
        let world = self.skeleton.world_matrices(pose);
        let mut mesh = TriMesh::default();
        for m in &self.meshes {
            let offset = mesh.vertices.len() as u32;
            let (positions, _) = m.skin(&world);
            mesh.vertices.extend(positions);
            mesh.triangles
                .extend(m.triangles.iter().map(|t| t.map(|i| i + offset)));
        }
        mesh.normals = Some(mesh.vertex_normals_from_faces());
        mesh
    }
}

/// The tip of a leaf bone whose skin is `points` (in the joint's bind frame): along the
/// points' centroid, as far as the farthest point along it. `None` when the points do not
/// lie to one side of the joint or the tip is shorter than `min_length`.
fn skin_tip(points: &[Point3], min_length: f64) -> Option<Vector3> {
    if points.len() < 3 {
        return None;
    }
    let centroid = points.iter().map(|p| p.coords).sum::<Vector3>() / points.len() as f64;
    let farthest = points.iter().map(|p| p.coords.norm()).fold(0.0, f64::max);
    if centroid.norm() < TIP_SIDEDNESS * farthest {
        return None;
    }
    let direction = centroid.try_normalize(1e-300)?;
    let length = points
        .iter()
        .map(|p| p.coords.dot(&direction))
        .fold(0.0, f64::max);
    (length >= min_length && length > 0.0).then(|| direction * length)
}

/// Whether `p` lies along the segment from `from` to `to`: past its first quarter and
/// within a third of its length of it.
fn near_segment(p: &Point3, from: &Point3, to: &Point3) -> bool {
    let along = to - from;
    let length = along.norm();
    if length <= 0.0 {
        return false;
    }
    let t = (p - from).dot(&along) / (length * length);
    if !(TIP_SIDEDNESS..=1.2).contains(&t) {
        return false;
    }
    (p - (from + along * t.min(1.0))).norm() < length / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::animation::{AnimationChannel, Interpolation};
    use crate::math::{Trs, Vector3};
    use crate::skeleton::Joint;

    #[test]
    fn a_helper_linking_the_skin_translates_as_its_clip_moves_it_an_ik_goal_does_not() {
        let at = |x: f64, y: f64| Trs::from_translation(Vector3::new(x, y, 0.0));
        let mut joints = vec![
            Joint::new("Body", None, at(0.0, 1.0)),
            Joint::new("Hip", Some(0), at(0.0, 0.0)),
            Joint::new("Leg", Some(1), at(0.0, -0.5)),
            Joint::new("Goal", Some(0), at(0.5, 0.0)),
        ];
        joints[1].kind = JointKind::Helper;
        joints[3].kind = JointKind::Helper;
        let mut skeleton = Skeleton::new(joints).expect("a tree");
        skeleton.set_default_dofs();
        let pose = skeleton.rest_pose();
        let drop = |joint: usize, rest: [f64; 4]| AnimationChannel {
            joint,
            target: ChannelTarget::Translation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: vec![rest, [rest[0], rest[1] - 0.5, 0.0, 0.0]],
        };
        let mut rig = Rig {
            skeleton,
            pose,
            meshes: Vec::new(),
            animations: vec![Animation {
                name: "sit".into(),
                channels: vec![drop(1, [0.0; 4]), drop(3, [0.5, 0.0, 0.0, 0.0])],
                frame_time: None,
            }],
        };
        assert_eq!(rig.free_translating_joints(), 1);
        assert_eq!(rig.skeleton.joint(1).dof, JointDof::Free, "the hip");
        assert_ne!(rig.skeleton.joint(3).dof, JointDof::Free, "the IK goal");
        // The leg held 0.1 off its rest translation all clip long: an exporter's constant
        // offset, not a motion.
        let held = AnimationChannel {
            joint: 2,
            target: ChannelTarget::Translation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: vec![[0.1, -0.5, 0.0, 0.0]; 2],
        };
        rig.animations[0].channels.push(held);
        assert_eq!(rig.free_translating_joints(), 0, "only the hip moves");
        assert_ne!(rig.skeleton.joint(2).dof, JointDof::Free, "the leg");
    }

    /// An arm whose IK goal (a joint under the body carrying the hand) the clip moves with
    /// the arm's end: the goal is tied there; moved on its own, it is not.
    #[test]
    fn an_ik_goal_the_clips_keep_at_the_arms_end_is_tied_there() {
        let at = |x: f64, y: f64| Trs::from_translation(Vector3::new(x, y, 0.0));
        let joints = vec![
            Joint::new("Body", None, at(0.0, 1.0)),
            Joint::new("Arm", Some(0), at(0.2, 0.0)),
            Joint::new("Fore", Some(1), at(0.5, 0.0)),
            Joint::new("Wrist", Some(2), at(0.5, 0.0)),
            Joint::new("Goal", Some(0), at(1.2, 0.0)),
            Joint::new("Finger", Some(4), at(0.1, 0.0)),
        ];
        let mut skeleton = Skeleton::new(joints).expect("a tree");
        skeleton.set_default_dofs();
        let pose = skeleton.rest_pose();
        // The arm turns 0.8 rad about z; the goal follows the wrist (or, `apart`, rises).
        let clip = |apart: bool| {
            let times: Vec<f64> = (0..=16).map(|k| k as f64 / 16.0).collect();
            let angle = |t: f64| 0.8 * t;
            let turn = AnimationChannel {
                joint: 1,
                target: ChannelTarget::Rotation,
                interpolation: Interpolation::Linear,
                times: times.clone(),
                values: times
                    .iter()
                    .map(|&t| {
                        let q = crate::math::Quat::from_axis_angle(&Vector3::z_axis(), angle(t));
                        crate::animation::quat_to_xyzw(&q)
                    })
                    .collect(),
            };
            let goal = AnimationChannel {
                joint: 4,
                target: ChannelTarget::Translation,
                interpolation: Interpolation::Linear,
                times: times.clone(),
                values: times
                    .iter()
                    .map(|&t| {
                        if apart {
                            [1.2, 0.5 * t, 0.0, 0.0]
                        } else {
                            [0.2 + angle(t).cos(), angle(t).sin(), 0.0, 0.0]
                        }
                    })
                    .collect(),
            };
            Animation {
                name: "reach".into(),
                channels: vec![turn, goal],
                frame_time: None,
            }
        };
        for apart in [false, true] {
            let mut rig = Rig {
                skeleton: skeleton.clone(),
                pose: pose.clone(),
                meshes: Vec::new(),
                animations: vec![clip(apart)],
            };
            assert_eq!(rig.free_translating_joints(), 1, "the goal translates");
            let tied = rig.tie_goals();
            let tie = rig.skeleton.joint(4).tie;
            if apart {
                assert_eq!((tied, tie), (0, None));
            } else {
                assert_eq!(tied, 1);
                let tie = tie.expect("tied");
                assert_eq!(tie.to, 3, "to the wrist, the nearest joint that keeps it");
                assert!(tie.offset.norm() < 1e-3, "{:?}", tie.offset);
                // A pose with the arm turned and the goal left behind: put back at the wrist.
                let mut turned = rig.skeleton.rest_pose();
                turned.local[1].rotation =
                    crate::math::Quat::from_axis_angle(&Vector3::z_axis(), 1.2);
                rig.skeleton.apply_ties(&mut turned);
                let at = rig.skeleton.joint_positions(&turned);
                assert!(
                    (at[4] - at[3]).norm() < 1e-3,
                    "{} from the wrist",
                    (at[4] - at[3]).norm()
                );
            }
        }
    }

    /// Two hip nodes a sit clip drops and turns together, each carrying a leg: the first is
    /// the leader (the second is tied to it) and gets the clip's transforms farthest apart,
    /// the farthest first; the second gets its own at the same times; a rig whose clips
    /// translate nothing below the root gets none.
    #[test]
    fn hips_a_sit_clip_drops_get_its_places_the_tied_one_at_the_same_times() {
        let at = |x: f64, y: f64| Trs::from_translation(Vector3::new(x, y, 0.0));
        let mut joints = vec![
            Joint::new("Body", None, at(0.0, 1.0)),
            Joint::new("HipL", Some(0), at(-0.1, 0.0)),
            Joint::new("LegL", Some(1), at(0.0, -0.5)),
            Joint::new("HipR", Some(0), at(0.1, 0.0)),
            Joint::new("LegR", Some(3), at(0.0, -0.5)),
        ];
        joints[1].kind = JointKind::Helper;
        joints[3].kind = JointKind::Helper;
        let mut skeleton = Skeleton::new(joints).expect("a tree");
        skeleton.set_default_dofs();
        let pose = skeleton.rest_pose();
        let times: Vec<f64> = (0..=16).map(|k| k as f64 / 16.0).collect();
        let drop = |joint: usize, x: f64| AnimationChannel {
            joint,
            target: ChannelTarget::Translation,
            interpolation: Interpolation::Linear,
            times: times.clone(),
            values: times.iter().map(|&t| [x, -0.5 * t, 0.0, 0.0]).collect(),
        };
        let turn = |joint: usize| AnimationChannel {
            joint,
            target: ChannelTarget::Rotation,
            interpolation: Interpolation::Linear,
            times: times.clone(),
            values: times
                .iter()
                .map(|&t| {
                    let q = crate::math::Quat::from_axis_angle(&Vector3::x_axis(), 1.4 * t);
                    crate::animation::quat_to_xyzw(&q)
                })
                .collect(),
        };
        let mut rig = Rig {
            skeleton,
            pose,
            meshes: Vec::new(),
            animations: vec![Animation {
                name: "sit".into(),
                channels: vec![drop(1, -0.1), turn(1), drop(3, 0.1), turn(3)],
                frame_time: None,
            }],
        };
        let mut still = rig.clone();
        still.animations[0]
            .channels
            .retain(|c| c.target == ChannelTarget::Rotation);
        assert_eq!(still.note_clip_places(), 0, "nothing translates");

        assert_eq!(rig.free_translating_joints(), 2);
        assert_eq!(rig.tie_goals(), 1);
        let (leader, follower) = match rig.skeleton.joint(3).tie {
            Some(tie) => (tie.to, 3),
            None => (3, 1),
        };
        assert_eq!(rig.note_clip_places(), 2);
        let places = &rig.skeleton.joint(leader).clip_places;
        let followed = &rig.skeleton.joint(follower).clip_places;
        assert!(
            places.len() >= 2 && places.len() <= CLIP_PLACES,
            "{}",
            places.len()
        );
        assert_eq!(followed.len(), places.len());
        // The farthest first: the whole drop and turn.
        assert!(
            (places[0].translation.y + 0.5).abs() < 1e-9,
            "{:?}",
            places[0]
        );
        assert!((places[0].rotation.angle() - 1.4).abs() < 1e-6);
        // The tied hip at the same times: its own side, as far down.
        for (a, b) in places.iter().zip(followed) {
            assert!((a.translation.y - b.translation.y).abs() < 1e-9);
            assert!((a.translation.x + b.translation.x).abs() < 1e-9);
        }
        // Every place apart from the others and from rest (a radian is a quarter height).
        let size = rig.height();
        let rest = rig.skeleton.joint(leader).rest;
        for (i, a) in places.iter().enumerate() {
            for b in places[..i].iter().chain(std::iter::once(&rest)) {
                let apart = (a.translation - b.translation).norm() / size
                    + CLIP_PLACE_TURN * a.rotation.angle_to(&b.rotation);
                assert!(apart >= CLIP_PLACE_APART, "{apart}");
            }
        }
        assert!(
            rig.skeleton.joint(2).clip_places.is_empty(),
            "the legs do not translate"
        );
    }

    /// A hip node a clip drops, in so many clips that their samples would exceed what the
    /// searches may hold: no clip places and no ties, at once.
    #[test]
    fn too_many_clip_samples_get_no_places() {
        let at = |x: f64, y: f64| Trs::from_translation(Vector3::new(x, y, 0.0));
        let mut joints = vec![
            Joint::new("Body", None, at(0.0, 1.0)),
            Joint::new("Hip", Some(0), at(0.0, 0.0)),
            Joint::new("Leg", Some(1), at(0.0, -0.5)),
        ];
        joints[1].kind = JointKind::Helper;
        let mut skeleton = Skeleton::new(joints).expect("a tree");
        skeleton.set_default_dofs();
        let pose = skeleton.rest_pose();
        let clip = Animation {
            name: "sit".into(),
            channels: vec![AnimationChannel {
                joint: 1,
                target: ChannelTarget::Translation,
                interpolation: Interpolation::Linear,
                times: vec![0.0, 1.0],
                values: vec![[0.0; 4], [0.0, -0.5, 0.0, 0.0]],
            }],
            frame_time: None,
        };
        let clips = SAMPLED_TRANSFORMS_BUDGET / TIE_SAMPLES + 1;
        let mut rig = Rig {
            skeleton,
            pose,
            meshes: Vec::new(),
            animations: vec![clip; clips],
        };
        assert_eq!(rig.free_translating_joints(), 1);
        assert_eq!(rig.tie_goals(), 0);
        assert_eq!(rig.note_clip_places(), 0);
        rig.animations.truncate(1);
        assert_eq!(rig.note_clip_places(), 1, "one clip is few enough");
    }

    /// Thousands of translated free joints are too many to look for ties in: none is
    /// tied, and the search returns at once (no world transforms built).
    #[test]
    fn too_many_goals_get_no_ties() {
        let at = |x: f64| Trs::from_translation(Vector3::new(x, 0.0, 0.0));
        let mut joints = vec![Joint::new("Root", None, at(0.0))];
        for k in 0..1000 {
            joints.push(Joint::new(format!("Goal{k}"), Some(0), at(1.0)));
            joints.push(Joint::new(format!("Hand{k}"), Some(2 * k + 1), at(0.1)));
        }
        let mut skeleton = Skeleton::new(joints).expect("a tree");
        for k in 0..1000 {
            skeleton.set_dof(2 * k + 1, JointDof::Free, None);
        }
        let pose = skeleton.rest_pose();
        let channels = (0..1000)
            .map(|k| AnimationChannel {
                joint: 2 * k + 1,
                target: ChannelTarget::Translation,
                interpolation: Interpolation::Linear,
                times: vec![0.0, 1.0],
                values: vec![[1.0, 0.0, 0.0, 0.0], [1.0, 0.5, 0.0, 0.0]],
            })
            .collect();
        let mut rig = Rig {
            skeleton,
            pose,
            meshes: Vec::new(),
            animations: vec![Animation {
                name: "all".into(),
                channels,
                frame_time: None,
            }],
        };
        assert_eq!(rig.tie_goals(), 0);
        assert!(rig.skeleton.joints().iter().all(|j| j.tie.is_none()));
    }
}
