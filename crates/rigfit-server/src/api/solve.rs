//! The solve handler of `/api`: a solve request parsed and solved on the blocking pool
//! (stopped when the client goes or at the solve timeout), answered with the pose report
//! and the character's joints.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use axum::Json;
use axum::extract::{Path as UrlPath, Request, State};
use axum::http::StatusCode;
use rigfit_core::JointDof;
use rigfit_core::interrupt::Interrupt;
use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, solve_pose_interruptible};
use rigfit_formats::json::parse_json;
use rigfit_formats::report::pose_report;
use rigfit_formats::strokes::strokes_from_json;
use serde_json::{Value, json};

use super::{REQUEST_LIMIT, bad_body, character, read_body, run_blocking};
use crate::AppState;
use crate::characters::Character;
use crate::error::ApiError;
use crate::guard::{JSON_TYPES, require_content_type};
use crate::request::{self, Limits};

/// Sets its flag when dropped: a request whose future is dropped before it finished (the
/// client closed the connection, or the server is shutting down) cancels its solve.
#[derive(Debug)]
struct CancelOnDrop(Arc<AtomicBool>);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// `POST /api/characters/{id}/solve`: poses the character from strokes. The solve stops
/// when the client goes (the request is dropped) or at the server's solve timeout (503).
pub async fn solve(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
    request: Request,
) -> Result<Json<Value>, ApiError> {
    require_content_type(request.headers(), "solve request", JSON_TYPES)?;
    let found = character(&state, &id)?;
    let body = read_body(&state, request, REQUEST_LIMIT).await?;
    let cancelled = Arc::new(AtomicBool::new(false));
    let _cancel_on_drop = CancelOnDrop(Arc::clone(&cancelled));
    let timeout = state.config().solve_timeout;
    run_blocking(&state, move || {
        // The deadline runs from when the solve starts (not while it queues).
        let interrupt = Interrupt::never()
            .with_flag(cancelled)
            .with_deadline(Instant::now() + timeout);
        solve_request(&found, &body, &interrupt, timeout)
    })
    .await?
    .map(Json)
}

/// Parses and solves one solve request (on the blocking pool) until `interrupt`.
fn solve_request(
    character: &Character,
    body: &[u8],
    interrupt: &Interrupt,
    timeout: std::time::Duration,
) -> Result<Value, ApiError> {
    const WHAT: &str = "solve request";
    let rig = &character.rig_file.rig;
    let limits = Limits::for_rig(rig);
    let doc = parse_json(body).map_err(|e| bad_body(WHAT, &e))?;
    let obj = request::object(&doc).map_err(|e| bad_body(WHAT, &e))?;
    request::check_strokes(&doc, &limits).map_err(|e| bad_body(WHAT, &e))?;
    // An empty list is well-formed: the solver refuses it (422), as it does in the CLI.
    let strokes = match obj.get("strokes") {
        Some(Value::Array(list)) if list.is_empty() => Vec::new(),
        _ => strokes_from_json(&doc).map_err(|e| bad_body(WHAT, &e))?,
    };
    let posed_by_request = request::optional(obj, "pose").is_some();
    let start = match request::optional(obj, "pose") {
        None => rig.pose.clone(),
        Some(p) => request::pose("pose", p, &rig.skeleton, &rig.pose, &limits)
            .map_err(|e| bad_body(WHAT, &e))?,
    };
    let movable = request::optional(obj, "bones")
        .map(|b| request::names("bones", b, &limits))
        .transpose()
        .map_err(|e| bad_body(WHAT, &e))?;
    let options = match request::optional(obj, "method") {
        None => PoseOptions::default(),
        Some(m) => match request::word("method", m, &["rigfit", "paper"]) {
            Ok("paper") => PoseOptions::paper(),
            Ok(_) => PoseOptions::default(),
            Err(e) => return Err(bad_body(WHAT, &e)),
        },
    };
    let root = match request::optional(obj, "root") {
        None => RootMotion::Free,
        Some(r) => match request::word("root", r, &["free", "rotate", "fixed"]) {
            Ok("rotate") => RootMotion::Rotate,
            Ok("fixed") => RootMotion::Fixed,
            Ok(_) => RootMotion::Free,
            Err(e) => return Err(bad_body(WHAT, &e)),
        },
    };
    let restricted;
    let posing = &character.posing_skeleton;
    let skeleton = match root {
        RootMotion::Free => posing,
        RootMotion::Rotate => {
            restricted = restrict_roots(posing, JointDof::Ball);
            &restricted
        }
        RootMotion::Fixed => {
            restricted = restrict_roots(posing, JointDof::Fixed);
            &restricted
        }
    };
    let problem = PoseProblem {
        skeleton,
        start: &start,
        strokes: &strokes,
        movable: movable.as_deref(),
        height: rig.height(),
    };
    let t0 = Instant::now();
    let result = solve_pose_interruptible(&problem, &options, interrupt).map_err(|e| match e {
        // Stopped: at the deadline (a cancelled request has nobody to answer).
        PoseError::Interrupted => ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            format!(
                "{WHAT}: the solve took longer than {} s, the server's limit (send fewer or shorter strokes)",
                timeout.as_secs_f64()
            ),
        ),
        // A pose the request sent that leaves no bone of any length is the request's.
        PoseError::NoBones if posed_by_request => {
            ApiError::unprocessable(format!("{WHAT}: pose: {e}"))
        }
        // As the command line: problems of the rig name the rig's file.
        e if e.is_rig_problem() => {
            ApiError::unprocessable(format!("{}: {e}", character.rig_file.path.display()))
        }
        _ => ApiError::unprocessable(format!("{WHAT}: {e}")),
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut report = pose_report(
        rig,
        &result.pose,
        &result.stroke_bones,
        result.iterations,
        result.energy,
        seconds,
    );
    report["joints"] = Value::Array(answer_joints(rig, &result.pose));
    Ok(report)
}

/// What a solve may do with the character's root joints (the joints free to move and turn:
/// the skin root, or every root of a forest).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RootMotion {
    /// Move and turn (the solver's default).
    Free,
    /// Turn in place: the roots keep their translation.
    Rotate,
    /// Keep their transform.
    Fixed,
}

/// The skeleton with its free (root) joints given `dof` instead: `Ball` turns them in place,
/// `Fixed` keeps them as they start. (The solver's rigid multi-start only moves a free root.)
fn restrict_roots(skeleton: &rigfit_core::Skeleton, dof: JointDof) -> rigfit_core::Skeleton {
    let mut restricted = skeleton.clone();
    for j in 0..restricted.len() {
        let joint = restricted.joint(j);
        if joint.dof == JointDof::Free {
            let limits = joint.limits;
            restricted.set_dof(j, dof, limits);
        }
    }
    restricted
}

/// The solve answer's joints: every joint of the CHARACTER in its order (helpers included),
/// each with its `index` there, its parent's name, world position, and local rotation and
/// translation (a pose the page can send back as the next request's start); BVH End Sites
/// with `"end_site": true` as in the command line's report.
fn answer_joints(rig: &rigfit_core::Rig, pose: &rigfit_core::Pose) -> Vec<Value> {
    let skeleton = &rig.skeleton;
    let positions = skeleton.joint_positions(pose);
    skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let p = positions[j];
            let local = &pose.local[j];
            let t = local.translation;
            let mut value = json!({
                "index": j,
                "name": joint.name,
                "parent": joint.parent.map(|q| skeleton.joint(q).name.clone()),
                "position": [p.x, p.y, p.z],
                "rotation": rigfit_core::animation::quat_to_xyzw(&local.rotation),
                "translation": [t.x, t.y, t.z],
            });
            if joint.kind.is_tip() {
                value["end_site"] = json!(true);
            }
            value
        })
        .collect()
}
