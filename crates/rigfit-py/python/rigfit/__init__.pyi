"""rigfit: pose rigged characters from 3D strokes, track articulated bodies and deformable
surfaces through point clouds, and read and write rigs, meshes and point clouds.

Arrays go in as anything numpy can read as float64 and come out as numpy arrays.
Joints keep the order they were given in. Quaternions are ``[x, y, z, w]``. rigfit's
solvers assume y is up (the glTF and BVH convention). Every error is a ``RigfitError``
(a ``ValueError``) with one line naming the argument and the problem.
"""

from collections.abc import Sequence
from os import PathLike
from typing import Literal

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
Float2D = npt.NDArray[np.float64]
Int1D = npt.NDArray[np.int64]
Int2D = npt.NDArray[np.int64]

class RigfitError(ValueError):
    """Bad input, or a problem rigfit cannot solve; the message says which and why."""

class Skeleton:
    """A joint tree: names, parents and rest (bind) transforms relative to the parent."""

    def __init__(
        self,
        names: Sequence[str],
        parents: Sequence[int | None],
        rest_translations: ArrayLike,
        rest_rotations: ArrayLike,
        rest_scales: ArrayLike | None = None,
        end_sites: Sequence[bool] | None = None,
        helpers: Sequence[bool] | None = None,
    ) -> None:
        """``parents[i]``: index of joint i's parent, -1 or None for a root (any order).
        ``rest_translations`` (n, 3), ``rest_rotations`` (n, 4), ``rest_scales`` (n, 3,
        default ones). ``end_sites[i]``: a fixed tip with no joint below (a bone's tail).
        ``helpers[i]``: a node that carries a transform but is not part of the character."""
    def __len__(self) -> int: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def parents(self) -> Int1D:
        """Parent index of each joint, -1 for a root."""
    @property
    def end_sites(self) -> list[bool]:
        """Per joint, whether it is a fixed tip (a BVH End Site, a bone's tail)."""
    @property
    def helpers(self) -> list[bool]:
        """Per joint, whether it is a helper node (not part of the character, not posed)."""
    @property
    def rest_rotations(self) -> Float2D: ...
    @property
    def rest_translations(self) -> Float2D: ...
    def index(self, name: str) -> int:
        """Index of the joint called ``name``; ``RigfitError`` if there is none."""
    def joint_positions(
        self, rotations: ArrayLike | None = None, translations: ArrayLike | None = None
    ) -> Float2D:
        """World positions (n, 3) for local rotations (n, 4) / translations (n, 3)."""
    def world_matrices(
        self, rotations: ArrayLike | None = None, translations: ArrayLike | None = None
    ) -> npt.NDArray[np.float64]:
        """World matrices (n, 4, 4) for a pose."""
    def height(
        self, rotations: ArrayLike | None = None, translations: ArrayLike | None = None
    ) -> float:
        """The y extent of the joints (the largest extent when that is zero)."""

class PoseResult:
    """What ``solve_pose`` found, in the skeleton's joint order."""

    rotations: Float2D
    """Local rotations (n, 4)."""
    translations: Float2D
    """Local translations (n, 3)."""
    positions: Float2D
    """World positions (n, 3) after posing."""
    stroke_bones: list[list[str]]
    """Per stroke, the bones it was matched to along the stroke; empty for a stray."""
    iterations: int
    energy: float
    seconds: float

def solve_pose(
    skeleton: Skeleton,
    strokes: Sequence[ArrayLike],
    rotations: ArrayLike | None = None,
    translations: ArrayLike | None = None,
    *,
    bones: Sequence[str] | None = None,
    stroke_bones: Sequence[Sequence[str] | None] | None = None,
    height: float | None = None,
    method: Literal["rigfit", "paper"] = "rigfit",
) -> PoseResult:
    """Poses ``skeleton`` so its bones lie along 3D ``strokes`` ((m, 3) polylines in its
    world space), starting from local ``rotations`` / ``translations`` (rest by default).
    ``bones``: the joints that may move. ``stroke_bones[i]``: pins stroke i to bones.
    ``height``: the character's size (default: its joints' y extent)."""

def draw_strokes(
    skeleton: Skeleton,
    rotations: ArrayLike | None = None,
    translations: ArrayLike | None = None,
    *,
    height: float | None = None,
    noise: float = 0.01,
    min_chain_length: float = 0.1,
    drop_limbs: int = 0,
    stray_strokes: int = 0,
    seed: int = 0,
) -> tuple[list[Float2D], Int1D]:
    """Ground-truth strokes through the skeleton in a pose: one per limb chain at least
    ``min_chain_length`` long, with noise (lengths are fractions of the height), some limbs
    dropped, strays added. Returns the strokes and the
    indices of the joints on drawn chains."""

class Rig:
    """A rigged character read from a file."""

    @property
    def skeleton(self) -> Skeleton: ...
    @property
    def rotations(self) -> Float2D:
        """Local rotations (n, 4) of the stored pose."""
    @property
    def translations(self) -> Float2D:
        """Local translations (n, 3) of the stored pose."""
    @property
    def height(self) -> float:
        """Vertical extent of the skinned mesh (or of the joints)."""
    @property
    def animations(self) -> list[str]: ...
    def animation_range(self, animation: int = 0) -> tuple[float, float]:
        """(start, end) in seconds."""
    def frame_time(self, animation: int = 0) -> float | None: ...
    def sample(self, time: float, animation: int = 0) -> tuple[Float2D, Float2D]:
        """(rotations, translations) of an animation at ``time`` seconds."""
    def mesh(
        self, rotations: ArrayLike | None = None, translations: ArrayLike | None = None
    ) -> tuple[Float2D, Int2D]:
        """The skinned mesh ``(vertices (n, 3), faces (k, 3))`` in the stored pose with the
        given local rotations (n, 4) / translations (n, 3) put in."""
    def save(
        self,
        path: str | PathLike[str],
        rotations: ArrayLike,
        translations: ArrayLike | None = None,
    ) -> None:
        """Writes the rig in one pose (``.glb`` / ``.gltf`` / ``.bvh``), as ``rigfit pose -o``
        does: the stored pose with the local rotations (n, 4) (and translations (n, 3))
        put in. Written atomically; never over a file the rig was read from."""
    def save_animation(
        self,
        path: str | PathLike[str],
        rotations: ArrayLike,
        translations: ArrayLike | None = None,
        fps: float = 30.0,
    ) -> None:
        """Writes the rig animated through poses, as ``rigfit track -o`` does:
        ``rotations`` (frames, n, 4), ``translations`` (frames, n, 3) or None (the stored
        pose's), one frame every ``1 / fps`` seconds (a glTF's ``rigfit`` animation, or the
        BVH's frames). Written atomically."""

def load_rig(
    path: str | PathLike[str],
    *,
    skin: str | None = None,
    start_frame: int | Literal["rest"] | None = None,
) -> Rig:
    """Reads a ``.glb`` / ``.gltf`` (with a skin) or ``.bvh`` rig."""

class FrameFit:
    """What tracking one frame found, in the skeleton's joint order."""

    rotations: Float2D
    translations: Float2D
    positions: Float2D
    inlier: list[bool]
    inliers: int
    em_iterations: int
    start: Literal["tracked", "stored", "search", "recovered", "collapsed"]
    """How the fit was found: on from the previous frame; the first frame from the stored
    pose or from the search; a collapsed frame found again by the search, or not."""

class Tracker:
    """Articulated tracking (Dewaele et al. 2006) through point clouds, frame by frame."""

    def __init__(
        self,
        model: Rig | Skeleton,
        rotations: ArrayLike | None = None,
        translations: ArrayLike | None = None,
        *,
        noise: float = 0.01,
        max_motion: float = 0.04,
        method: Literal["rigfit", "paper"] = "rigfit",
        init: Literal["auto", "stored", "search"] = "auto",
        recover: bool = True,
    ) -> None:
        """From a ``Rig`` (its skinned mesh) or a ``Skeleton`` and a start pose.
        ``init="auto"`` keeps the start pose when it explains the first frame and otherwise
        searches for the body (anywhere, turned any way); ``"stored"`` always keeps it,
        ``"search"`` always searches. ``recover``: search again on a frame whose fit
        collapsed. ``noise`` / ``max_motion``: fractions of the height."""
    def track(self, points: ArrayLike) -> FrameFit:
        """Aligns the model to one frame's points (m, 3)."""
    def positions(self) -> Float2D:
        """Joint world positions (n, 3) in the current pose."""
    def surface_points(self) -> Float2D:
        """Model surface points (k, 3) in the current pose."""

def run_take(
    take: dict[str, object], base_dir: str | PathLike[str] | None = None
) -> dict[str, object]:
    """Runs one take (a dict as in a job file: ``name``, ``command`` = ``"pose"`` /
    ``"track"`` / ``"surface"``, and the command's arguments by their long names) as
    ``rigfit COMMAND`` would; relative paths start from ``base_dir`` (default: the current
    folder). Returns ``{"name", "command", "status", "summary", "seconds", "attempts"}``;
    raises ``RigfitError`` with the take's one line when it fails."""

def read_jobs(path: str | PathLike[str]) -> tuple[list[dict[str, object]], str]:
    """Reads and checks a job file; returns its takes (names filled in) and the folder
    their relative paths start from."""

def run_batch(
    path: str | PathLike[str],
    *,
    workers: int = 1,
    report: str | PathLike[str] | None = None,
    progress: bool = False,
) -> dict[str, object]:
    """Runs every take of a job file on ``workers`` threads, as ``rigfit batch`` does: a
    line on stderr per failed take, the others carrying on; returns the summary report
    (``done``, ``failed``, ``takes``) and writes it to ``report`` if given. Raises
    ``RigfitError`` only for a bad job file or report path."""

class SurfaceFit:
    """What tracking one frame of a surface found."""

    vertices: Float2D
    """The reference's vertices (n, 3) moved onto the frame, vertex for vertex."""
    inliers: int
    """How many of the frame's points were taken as inliers."""
    rms: float
    """Root mean square distance of the points to their vertices (posterior-weighted)."""
    iterations: int
    """EM iterations run."""
    sigma: float
    """The final kernel width, in the reference's units."""
    seconds: float
    """Wall time of the frame's fit."""

class SurfaceTracker:
    """Deformable surface tracking (Cagniart et al. 2010; ``rigfit surface``): a reference
    mesh, cut into patches that move rigidly and are held together by a rigidity energy,
    fitted by EM to each frame's points in turn, each frame starting from the previous one."""

    def __init__(
        self,
        vertices: ArrayLike,
        faces: ArrayLike,
        *,
        patch_radius: float = 0.06,
        outliers: float = 0.15,
        rigidity: float = 4.0,
        iterations: int = 25,
        merge: float = 0.0,
        coarse: int = 4,
        points_per_vertex: float = 1.0,
        fast_motion: bool = False,
        piece_tree: bool = True,
    ) -> None:
        """The reference: ``vertices`` (n, 3), ``faces`` (k, 3) vertex indices (required:
        they give the patches). The options, defaults and bounds are ``rigfit surface``'s:
        ``patch_radius`` (a fraction of the reference's bounding-box diagonal, 0.0001 to
        10), ``outliers`` (expected outlier fraction, [0, 1)), ``rigidity`` (>= 0),
        ``iterations`` (EM iterations per frame at most, 1 to 1000), ``merge`` (merge each
        frame's points by cubes of this many point spacings; 0: off), ``coarse`` (the first
        iterations, two or four with ``fast_motion``, use one point in this many, 1 to
        1024), ``points_per_vertex`` (on an object of rigid pieces, every iteration fits
        about this many points a reference vertex; 0: every point, >= 0), ``fast_motion`` (``--fast-motion``: for limbs that move a tenth of the object
        or more between frames, at about twice the time on such frames), ``piece_tree``
        (``False`` is ``--no-piece-tree``: a many-part object's patches start from their
        own motion continued, not from the pieces' kinematic tree)."""
    def track(
        self,
        points: ArrayLike,
        normals: ArrayLike | None = None,
        faces: ArrayLike | None = None,
    ) -> SurfaceFit:
        """Aligns the reference to one frame: ``points`` (m, 3), with ``normals`` (m, 3) and
        ``faces`` (k, 3) when the frame has them (otherwise normals come from the faces, or
        are estimated from the points, as ``rigfit surface`` reads a frame file)."""
    @property
    def vertices(self) -> Float2D:
        """The reference's vertices (n, 3) as tracked so far."""
    @property
    def faces(self) -> Int2D:
        """The reference's faces (k, 3)."""
    @property
    def patch_count(self) -> int:
        """How many patches the reference was cut into."""
    @property
    def options(self) -> dict[str, float | int]:
        """The options in force, by keyword."""

def load_mesh(path: str | PathLike[str]) -> tuple[Float2D, Int2D]:
    """Reads ``(vertices (n, 3), faces (k, 3))`` from a ``.ply`` / ``.obj`` mesh, or the
    skinned meshes of a ``.glb`` / ``.gltf`` rig in its stored pose (``rigfit surface``'s
    reference). A point cloud has faces of shape (0, 3)."""

def load_cloud(path: str | PathLike[str]) -> tuple[Float2D, Float2D | None]:
    """Reads ``(points (n, 3), normals (n, 3) or None)`` from a ``.ply`` / ``.obj`` file
    (``rigfit surface``'s frames)."""

def save_mesh(
    path: str | PathLike[str],
    vertices: ArrayLike,
    faces: ArrayLike | None = None,
    normals: ArrayLike | None = None,
) -> None:
    """Writes a mesh or point cloud as ``.ply`` (binary, 32-bit float coordinates, as
    ``rigfit surface`` writes its frames) or ``.obj`` (full precision), atomically."""
