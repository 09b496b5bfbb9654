# Typed stub of the tritrace extension module (python/module.cpp), so that editors complete and
# type checkers check calls; tests/python/test_stub.py keeps it in step with the module.
"""tritrace: fast, watertight ray queries and renders of triangle scenes on NumPy arrays."""

import os
from typing import Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str
accels: Tuple[str, ...]
"""The acceleration structures this build has: 'bvh', 'brute', 'bvh-single' and, where built,
'embree', 'embree-single', 'embree8', 'embree-robust'."""
kernels: Tuple[str, ...]
"""The ray/triangle kernels: 'inverse', 'cramer', 'moller-trumbore', 'watertight'."""

_Vec3 = Union[Sequence[float], npt.NDArray[np.floating], npt.NDArray[np.integer]]
_Rays = npt.ArrayLike
_Interval = Union[float, npt.ArrayLike]
_Path = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]

class CameraInfo(TypedDict):
    width: int
    height: int
    position: Tuple[float, float, float]
    look_at: Tuple[float, float, float]
    up: Tuple[float, float, float]
    forward: Tuple[float, float, float]
    focal_length: float
    vertical_fov: Optional[float]
    lab_orbit: bool
    aperture_radius: float
    focus_distance: Optional[float]
    orthographic: bool

class LightInfo(TypedDict):
    position: Tuple[float, float, float]
    power: Tuple[float, float, float]

class SpotLightInfo(TypedDict):
    position: Tuple[float, float, float]
    direction: Tuple[float, float, float]
    intensity: Tuple[float, float, float]
    inner_angle: float
    outer_angle: float
    falloff: str

class DirectionalLightInfo(TypedDict):
    direction: Tuple[float, float, float]
    irradiance: Tuple[float, float, float]

class Scene:
    """A triangle scene: geometry, materials, lights and a camera. Read-only once made.

    Make one with tritrace.load(path), Scene.builtin(name) or Scene.from_arrays(...).
    """

    @staticmethod
    def builtin(name: str) -> "Scene":
        """A built-in scene: "cornell" (the lab's box, 30 triangles), "cornell-area" (the box
        lit by a ceiling light) or "terrain:<triangles>" ("terrain:1m", "terrain:250k"), exactly
        as `tritrace render --scene NAME` builds it. ValueError for an unknown name."""
    @staticmethod
    def from_arrays(
        vertices: npt.ArrayLike,
        triangles: npt.ArrayLike,
        materials: Optional[npt.ArrayLike] = None,
    ) -> "Scene":
        """A scene of triangles given as arrays, set up as a mesh file is.

        vertices: (N, 3) numbers; triangles: (M, 3) integer vertex indices; materials: None (the
        neutral grey 0.6 of mesh files), one albedo (3,) for every triangle, or one per triangle
        (M, 3), each in [0, 1]. The camera is framed on the bounds, with a point light near it,
        as `tritrace render mesh.obj` does. Degenerate and non-finite triangles are dropped (with
        a RuntimeWarning); hits still report indices into `triangles`.
        """
    @property
    def source(self) -> str:
        """The file, the built-in scene's name, or 'arrays'."""
    @property
    def triangle_count(self) -> int:
        """Triangles in the scene (after dropping degenerate and non-finite ones)."""
    @property
    def dropped_degenerate(self) -> int:
        """Zero-area triangles dropped while loading."""
    @property
    def dropped_non_finite(self) -> int:
        """Triangles with a NaN or infinite vertex (or overflowing edges) dropped while loading."""
    @property
    def bounds(self) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """(lo, hi): the corners of the scene's bounding box, float32 arrays of shape (3,)."""
    @property
    def integrator(self) -> Literal["lab", "path", "bdpt"]:
        """The integrator the scene asks for when render() is given none."""
    @property
    def camera(self) -> CameraInfo:
        """The scene's own camera."""
    @property
    def lights(self) -> list[LightInfo]:
        """The point lights."""
    @property
    def spot_lights(self) -> list[SpotLightInfo]:
        """The spot lights (intensity in W/sr on the axis, cone angles in degrees)."""
    @property
    def directional_lights(self) -> list[DirectionalLightInfo]:
        """The directional lights (the way the light travels, irradiance in W/m^2)."""
    def camera_rays(
        self,
        *,
        width: Optional[int] = None,
        height: Optional[int] = None,
        yaw: Optional[float] = None,
        distance: Optional[float] = None,
        position: Optional[_Vec3] = None,
        look_at: Optional[_Vec3] = None,
        up: Optional[_Vec3] = None,
        vertical_fov: Optional[float] = None,
        focal_length: Optional[float] = None,
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
        """The camera's rays through every pixel's top-left corner, as the lab integrator traces
        them: (origin, directions), origin of shape (3,) and unit directions of shape
        (height, width, 3), float32. The keyword arguments are render()'s camera settings."""

def load(path: _Path) -> Scene:
    """Loads a scene file (.json) or a mesh file (anything assimp reads: .obj, .ply, .stl, .gltf,
    .glb, ...) as `tritrace render FILE` does. Raises OSError (FileNotFoundError,
    IsADirectoryError, PermissionError where they apply) with the CLI's message."""

class Hits:
    """The closest hits of a batch of rays, as arrays of the rays' shape.

    t: distance along each ray in units of its direction's length (inf where it missed); prim:
    triangle index (-1 where it missed); u, v: barycentric weights of the triangle's second and
    third vertices (0 where it missed; for Scene.from_arrays those of triangles[prim, 1] and
    triangles[prim, 2]); normal: (..., 3) unit geometric normal of the hit triangle, not turned
    toward the ray (0 where it missed), computed when first read: the counter-clockwise
    normalize(cross(b - a, c - a)) of each triangle (a, b, c) of Scene.from_arrays and of mesh
    files, the lab's normalize(cross(v2 - v0, v1 - v0)) in built-in scenes and scene files'
    inline meshes; hit: prim >= 0.
    """

    @property
    def t(self) -> npt.NDArray[np.float32]: ...
    @property
    def prim(self) -> npt.NDArray[np.int32]: ...
    @property
    def u(self) -> npt.NDArray[np.float32]: ...
    @property
    def v(self) -> npt.NDArray[np.float32]: ...
    @property
    def normal(self) -> npt.NDArray[np.float32]: ...
    @property
    def hit(self) -> npt.NDArray[np.bool_]: ...

class Accel:
    """An acceleration structure over a scene's triangles, for batched ray queries.

    kind is one of tritrace.accels ("bvh", "bvh-single", "brute", and the Embree modes where
    built); kernel one of tritrace.kernels, by default the watertight kernel (Embree always uses
    its own). Queries release the GIL, use every core and may run from several threads at once.
    """

    def __init__(self, scene: Scene, kind: str = "bvh", kernel: Optional[str] = None) -> None: ...
    def intersect(
        self,
        origins: _Rays,
        directions: _Rays,
        tmin: _Interval = 0.0,
        tmax: _Interval = float("inf"),
        *,
        coherent: Optional[bool] = None,
    ) -> Hits:
        """The closest hit of each ray within [tmin, tmax].

        origins and directions: arrays of shape (..., 3), or (3,) for one shared by every ray;
        any real dtype (C-contiguous float32 is read in place, anything else converted once).
        tmin and tmax: numbers, or arrays of the rays' shape. Directions need not be unit
        length: t is in units of their length. A ray with a non-finite origin or direction, a
        zero direction, a negative or NaN tmin or a NaN tmax raises ValueError naming the first
        one. coherent: None chooses per batch of 256 rays between packet traversal and single
        rays; True or False forces one. The hits are the same either way, bit for bit.
        """
    def occluded(
        self,
        origins: _Rays,
        directions: _Rays,
        tmin: _Interval = 0.0,
        tmax: _Interval = float("inf"),
        *,
        coherent: Optional[bool] = None,
    ) -> npt.NDArray[np.bool_]:
        """Whether each ray hits any triangle within [tmin, tmax]: a bool array of the rays'
        shape. Arguments as for intersect()."""
    @property
    def kind(self) -> str: ...
    @property
    def kernel(self) -> str: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def build_ms(self) -> float: ...

class FirstHits(TypedDict):
    t: npt.NDArray[np.float32]
    geometry_ids: npt.NDArray[np.int32]
    primitive_ids: npt.NDArray[np.int32]
    primitive_uvs: npt.NDArray[np.float32]
    primitive_normals: npt.NDArray[np.float32]

class Intersections(TypedDict):
    ray_splits: npt.NDArray[np.int64]
    ray_ids: npt.NDArray[np.int32]
    t: npt.NDArray[np.float32]
    geometry_ids: npt.NDArray[np.int32]
    primitive_ids: npt.NDArray[np.int32]
    primitive_uvs: npt.NDArray[np.float32]

class ClosestPoints(TypedDict):
    points: npt.NDArray[np.float32]
    geometry_ids: npt.NDArray[np.int32]
    primitive_ids: npt.NDArray[np.int32]
    primitive_uvs: npt.NDArray[np.float32]
    primitive_normals: npt.NDArray[np.float32]

class QueryScene:
    """Several triangle meshes in one BVH for geometric queries.

    QueryScene() is empty; add(vertices, triangles) appends a mesh and returns its geometry id (0,
    1, 2, ... in the order added). Every query answers with the geometry id and the triangle's
    index in that geometry's triangles array. The BVH (watertight kernel) is built on the first
    query after an add(). Queries release the GIL, use every core and may run from several
    threads at once.
    """

    def __init__(self) -> None: ...
    def add(self, vertices: npt.ArrayLike, triangles: npt.ArrayLike) -> int:
        """Appends a mesh; returns its geometry id.

        vertices: (N, 3) numbers (converted to float32; each must be finite); triangles: (M, 3)
        integer indices into vertices. Zero-area triangles are kept, so that triangle indices
        stay yours: rays never hit them. ValueError naming the argument for a bad shape, value or
        index.
        """
    @property
    def geometry_count(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    def intersect(
        self,
        origins: _Rays,
        directions: _Rays,
        tmin: _Interval = 0.0,
        tmax: _Interval = float("inf"),
    ) -> FirstHits:
        """The first hit of each ray within [tmin, tmax].

        origins and directions: arrays of shape (..., 3), or (3,) for one shared by every ray;
        tmin and tmax: numbers or arrays of the rays' shape; t is in units of each direction's
        length. Returns arrays of the rays' shape: t (inf on a miss), geometry_ids and
        primitive_ids (-1 on a miss), primitive_uvs (..., 2) barycentric weights of the
        triangle's second and third vertices, primitive_normals (..., 3) unit normal
        normalize(cross(b - a, c - a)) of the triangle (a, b, c) as given (0 on a miss). A bad
        ray raises ValueError naming the argument and the first such ray.
        """
    def count_intersections(
        self,
        origins: _Rays,
        directions: _Rays,
        tmin: _Interval = 0.0,
        tmax: _Interval = float("inf"),
    ) -> npt.NDArray[np.int32]:
        """How many triangles each ray crosses within [tmin, tmax], an array of the rays' shape.

        Each crossing counts once, also through an edge or vertex shared by several triangles:
        the count along a line through a closed mesh is even, and its parity from a point says
        whether the point is inside. A ray that only grazes an edge or touches a vertex counts 0
        or 2 there; triangles seen edge-on and zero-area triangles are never crossed.
        """
    def list_intersections(
        self,
        origins: _Rays,
        directions: _Rays,
        tmin: _Interval = 0.0,
        tmax: _Interval = float("inf"),
    ) -> Intersections:
        """Every crossing of each ray within [tmin, tmax], as count_intersections() counts them.

        Flat arrays, ray by ray (rays in C order of their shape) and by increasing t: ray i's
        crossings are [ray_splits[i], ray_splits[i + 1]); ray_ids names each crossing's ray;
        primitive_uvs are the barycentric weights of the triangle's second and third vertices.
        """
    def closest_points(self, points: npt.ArrayLike) -> ClosestPoints:
        """The nearest surface point to each query point.

        points: array of shape (..., 3) (converted to float32; every value finite). Returns arrays
        of the points' leading shape: points (..., 3), the nearest point on any geometry;
        geometry_ids and primitive_ids of its triangle; primitive_uvs (..., 2) barycentric
        weights of the triangle's second and third vertices there; primitive_normals (..., 3)
        unit normal normalize(cross(b - a, c - a)) of the triangle (a, b, c) as given (0 for a
        zero-area one). Exact (Ericson's regions in double); ties go to the triangle added first.
        An empty scene gives points at inf and ids -1. ValueError naming points for a bad shape
        or a value that is not finite.
        """
    def distance(self, points: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """The distance to the nearest surface point, of the points' leading shape."""
    def signed_distance(self, points: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """distance() negative inside, positive outside, +0 on the surface.

        Inside: the generalised winding number of all geometries (Jacobson et al. 2013, evaluated
        hierarchically after Barill et al. 2018, exactly near the surface) above 1/2 in
        magnitude, whichever way a closed mesh's triangles face. A RuntimeWarning names every
        geometry with boundary, non-manifold or inconsistently oriented edges.
        """
    def occupancy(self, points: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """1.0 inside, 0.0 outside (signed_distance's inside), of the points' leading shape;
        the same RuntimeWarning for geometries that are not closed.
        """

class Frame:
    """A rendered image and its AOVs.

    image: (height, width, 3) linear radiance, row 0 at the top (a PFM file stores rows
    bottom-up); albedo, normal: (height, width, 3) and depth: (height, width), or None when not
    asked for; variance: (height, width, 3), the estimated variance of each pixel's mean (from the
    halves of its samples split by sample index parity), or None.
    """

    @property
    def image(self) -> npt.NDArray[np.float32]: ...
    @property
    def albedo(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def normal(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def depth(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def variance(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def integrator(self) -> Literal["lab", "path", "bdpt"]: ...
    @property
    def spp(self) -> int: ...
    @property
    def mean_spp(self) -> float: ...
    @property
    def light_paths(self) -> float: ...
    @property
    def spp_map(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def milliseconds(self) -> float: ...
    @property
    def rays(self) -> int: ...
    @property
    def threads(self) -> int: ...

def render(
    scene: Scene,
    *,
    integrator: Optional[Literal["lab", "path", "bdpt"]] = None,
    spp: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: Optional[int] = None,
    sampler: Optional[Literal["sobol", "independent"]] = None,
    max_depth: Optional[int] = None,
    filter: Optional[Literal["box", "gaussian", "blackman-harris"]] = None,
    aovs: Sequence[Literal["albedo", "normal", "depth", "variance", "spp"]] = (),
    accel: Union[str, Accel, None] = None,
    kernel: Optional[str] = None,
    threads: Optional[int] = None,
    position: Optional[_Vec3] = None,
    look_at: Optional[_Vec3] = None,
    up: Optional[_Vec3] = None,
    vertical_fov: Optional[float] = None,
    focal_length: Optional[float] = None,
    yaw: Optional[float] = None,
    distance: Optional[float] = None,
    light: Optional[_Vec3] = None,
    time_limit: Optional[float] = None,
    denoise: Optional[bool] = None,
    clamp: Optional[float] = None,
    noise_threshold: Optional[float] = None,
    aperture: Optional[float] = None,
    focus: Optional[float] = None,
    light_paths: Union[float, Literal["auto"], None] = None,
) -> Frame:
    """Renders the scene as `tritrace render` does: the image is bit for bit the one
    `tritrace render ... -o out.pfm` writes with the same settings.

    Every argument left None is the scene's own (or the CLI's default). accel: a name, or an
    Accel built over this scene (reused across renders). Camera settings beyond the CLI's flags,
    as a scene file's camera has them: position, look_at, up, vertical_fov (degrees) or
    focal_length (pixels); giving any to a built-in scene replaces the lab's orbit camera with a
    look-at camera. time_limit (seconds): the path tracer's samples in passes until the time is
    up (spp the most); Frame.spp says how many it reached. denoise=True: the image through the
    built-in denoiser, as `tritrace render --denoise`. clamp: the most one sample's indirect light
    adds to a pixel (biased, as `tritrace render --clamp`). noise_threshold: adaptive sampling
    as `tritrace render --noise-threshold`: after 64 samples each pixel takes more in proportion to
    its neighbours' relative error over the threshold (never its own, so the image is unbiased; spp
    the most); Frame.mean_spp says how many a pixel took on average, aovs "spp" gives
    Frame.spp_map. aperture and focus: a thin lens's radius and the distance of the plane in
    focus, as --aperture and --focus. light_paths (bdpt only): the share of samples, in (0, 1],
    that also trace a light subpath, as `tritrace render --light-paths`, or "auto" (the default):
    a pilot chooses it for the scene among 1, 1/2, 1/4, ..., 1/64 (Frame.light_paths says
    which). Bad values raise ValueError with the
    CLI's message, wrong types TypeError.
    """


def denoise(
    color: npt.ArrayLike,
    albedo: Optional[npt.ArrayLike] = None,
    normal: Optional[npt.ArrayLike] = None,
    depth: Optional[npt.ArrayLike] = None,
    variance: Optional[npt.ArrayLike] = None,
    *,
    search_radius: int = 7,
    sampler: Literal["sobol", "independent"] = "sobol",
    threads: Optional[int] = None,
) -> npt.NDArray[np.float32]:
    """Denoises an image with the built-in feature-guided denoiser, as `tritrace denoise`
    denoises an EXR with the same layers; returns a new float32 (height, width, 3) array.

    color: (height, width, 3) linear radiance. albedo and normal: (height, width, 3), depth:
    (height, width): the first non-specular hit's features as render() returns them (aovs
    "albedo", "normal", "depth"), or None to leave that feature out (without albedo the colour
    is not divided by it). variance: (height, width, 3), the variance of each pixel's mean
    (render()'s aovs "variance"), averaged over 5 x 5 pixels as `tritrace denoise` averages an
    EXR's variance layer; None estimates it from the image (larger than the truth at edges).
    sampler: the sampler the render used, "sobol" (render()'s default) or "independent": the
    variance of the Sobol sampler's sample halves is about twice the truth and is halved, the
    independent sampler's is taken as it is. So denoise(f.image, f.albedo, f.normal, f.depth,
    f.variance, sampler=s) of a render f with sampler s is the image render(..., denoise=True)
    returns, bit for bit. Any real dtype (converted once to float32);
    every value must be finite. search_radius: 1 to 32 (a (2r+1)^2 window; larger smooths more
    and takes longer). threads: None (all cores) or a count; the result is the same for any.
    Releases the GIL while filtering. Bad shapes or values raise ValueError naming the
    argument, wrong types TypeError.
    """
