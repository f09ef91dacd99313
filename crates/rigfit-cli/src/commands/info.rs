//! `rigfit info FILE`: what a file holds.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::bail;
use rigfit_core::{Aabb, JointDof, JointKind, Rig};
use rigfit_formats::error::extension;
use rigfit_formats::rig_file::{RigOptions, RigSource, read_rig};

#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// A rig (.glb, .gltf, .bvh), a mesh or point cloud (.ply, .obj) or a strokes file (.json).
    file: PathBuf,
    /// The glTF skin to describe (by name); the first by default.
    #[arg(long)]
    skin: Option<String>,
}

pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    super::check_rig_options(&args.file, args.skin.as_deref(), None)?;
    let text = describe(&args.file, args.skin.as_deref())?;
    // A reader that stops early (`rigfit info big.glb | head`) is no error.
    match std::io::Write::write_all(&mut std::io::stdout().lock(), text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow::anyhow!("writing to stdout: {e}"))
        }
        _ => Ok(()),
    }
}

/// The description printed by `rigfit info`.
pub fn describe(path: &Path, skin: Option<&str>) -> anyhow::Result<String> {
    let mut out = String::new();
    match extension(path).as_str() {
        "glb" | "gltf" => {
            let doc = rigfit_formats::gltf::read_gltf(path, skin)?;
            writeln!(
                out,
                "{}: glTF 2.0 ({})",
                path.display(),
                if extension(path) == "glb" {
                    "binary"
                } else {
                    "JSON"
                }
            )?;
            let skins = doc
                .json
                .get("skins")
                .and_then(|s| s.as_array())
                .map_or(0, Vec::len);
            writeln!(out, "skins: {skins}")?;
            if let Some(rig) = &doc.rig {
                describe_rig(&mut out, rig)?;
            }
            let meshes = doc.mesh_summaries();
            writeln!(out, "meshes: {}", meshes.len())?;
            for m in meshes {
                let skinned = if m.skinned { ", skinned" } else { "" };
                writeln!(
                    out,
                    "  {}: {} vertices, {} triangles{skinned}",
                    m.name, m.vertices, m.triangles
                )?;
            }
            if let Some(rig) = &doc.rig {
                describe_extent(&mut out, rig)?;
            }
        }
        "bvh" => {
            let file = read_rig(path, &RigOptions::default())?;
            let RigSource::Bvh(doc) = &file.source else {
                unreachable!("a .bvh path gives a BVH source")
            };
            writeln!(out, "{}: BVH motion capture", path.display())?;
            describe_rig(&mut out, &file.rig)?;
            writeln!(
                out,
                "frames: {} at {} s ({:.1} fps)",
                doc.frames.len(),
                doc.frame_time,
                1.0 / doc.frame_time
            )?;
            describe_extent(&mut out, &file.rig)?;
        }
        "ply" | "obj" => {
            let mesh = if extension(path) == "ply" {
                rigfit_formats::ply::read_ply(path)?
            } else {
                rigfit_formats::obj::read_obj(path)?
            };
            let kind = if mesh.is_point_cloud() {
                "point cloud"
            } else {
                "mesh"
            };
            writeln!(out, "{}: {kind}", path.display())?;
            writeln!(out, "points: {}", mesh.vertices.len())?;
            writeln!(out, "triangles: {}", mesh.triangles.len())?;
            writeln!(
                out,
                "normals: {}",
                if mesh.normals.is_some() { "yes" } else { "no" }
            )?;
            write_bounds(&mut out, mesh.bounds())?;
        }
        "json" => {
            let strokes = rigfit_formats::strokes::read_strokes(path)?;
            writeln!(out, "{}: strokes", path.display())?;
            writeln!(out, "strokes: {}", strokes.len())?;
            for (i, s) in strokes.iter().enumerate() {
                let pinned = s
                    .bones
                    .as_ref()
                    .map(|b| format!(", pinned to {}", b.join(", ")))
                    .unwrap_or_default();
                writeln!(
                    out,
                    "  {i}: {} points, length {:.4}{pinned}",
                    s.points.len(),
                    s.length()
                )?;
            }
            write_bounds(
                &mut out,
                Aabb::from_points(strokes.iter().flat_map(|s| &s.points)),
            )?;
        }
        _ => bail!(
            "{}: unsupported file type (expected .glb, .gltf, .bvh, .ply, .obj or a strokes .json)",
            path.display()
        ),
    }
    Ok(out)
}

/// The deepest indentation of the joint tree.
const MAX_INDENT: usize = 32;

fn describe_rig(out: &mut String, rig: &Rig) -> anyhow::Result<()> {
    let s = &rig.skeleton;
    let count = |k: JointKind| s.joints().iter().filter(|j| j.kind == k).count();
    writeln!(
        out,
        "joints: {} ({} skin joints, {} end sites, {} helper nodes)",
        s.len(),
        count(JointKind::Skin),
        count(JointKind::EndSite),
        count(JointKind::Helper)
    )?;
    // Depth first, parents before children, with an explicit stack (a chain of any depth);
    // the indentation stops growing at MAX_INDENT levels, deeper joints show their depth,
    // so the text grows linearly with the number of joints.
    let mut stack: Vec<(usize, usize)> = s.roots().map(|r| (r, 0)).collect();
    stack.reverse();
    while let Some((j, depth)) = stack.pop() {
        let joint = s.joint(j);
        let kind = match joint.kind {
            JointKind::Skin => "",
            JointKind::Helper => " (helper)",
            JointKind::EndSite => " (end site)",
            JointKind::SkinTip => " (tip from the skin)",
        };
        let dof = match joint.dof {
            JointDof::Free => " [free]",
            JointDof::Ball => "",
            JointDof::Hinge { .. } => " [hinge]",
            JointDof::Fixed => " [fixed]",
        };
        let indent = "  ".repeat(depth.min(MAX_INDENT));
        let deep = if depth > MAX_INDENT {
            format!("(depth {depth}) ")
        } else {
            String::new()
        };
        // An IK goal the clips keep at the end of a limb (`Rig::tie_goals`).
        let tie = joint
            .tie
            .map(|t| format!(" (tied to {})", s.joint(t.to).name))
            .unwrap_or_default();
        writeln!(out, "  {indent}{deep}{}{kind}{dof}{tie}", joint.name)?;
        stack.extend(s.children(j).iter().rev().map(|&c| (c, depth + 1)));
    }
    writeln!(out, "animations: {}", rig.animations.len())?;
    for a in &rig.animations {
        writeln!(
            out,
            "  {}: {:.3} s, {} frames, {} channels",
            a.name,
            a.duration(),
            a.frame_count(),
            a.channels.len()
        )?;
    }
    Ok(())
}

fn describe_extent(out: &mut String, rig: &Rig) -> anyhow::Result<()> {
    write_bounds(out, rig.bounds(&rig.pose))?;
    writeln!(out, "height: {:.4}", rig.height())?;
    Ok(())
}

fn write_bounds(out: &mut String, b: Option<Aabb>) -> anyhow::Result<()> {
    match b {
        Some(b) => {
            writeln!(
                out,
                "bounding box: min [{:.4}, {:.4}, {:.4}] max [{:.4}, {:.4}, {:.4}]",
                b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
            )?;
            writeln!(out, "diagonal: {:.4}", b.diagonal())?;
        }
        None => writeln!(out, "bounding box: empty")?,
    }
    Ok(())
}
