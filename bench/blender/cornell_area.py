"""tritrace's built-in `cornell-area` scene rebuilt in Blender Cycles, from the lab fact sheet's
numbers (../shared/lab-cornell-box.md and src/tritrace/scene/cornell_box.cpp), for a side-by-side
speed and noise comparison (docs/PERFORMANCE.md, "Path tracing against Blender Cycles").

Run (Blender 3.4, Debian 12's `blender`; no .blend file is involved):

    blender -b --factory-startup --python bench/blender/cornell_area.py -- \
        --spp 1024 --out /tmp/cycles.exr --threads 2 --size 256 [--bounces 128] [--seed 0]

It writes a linear float OpenEXR (RGBA, full float) and, next to it, a PFM with the same pixels
(the format `tritrace render -o x.pfm` writes, so bench/blender/compare.py needs only numpy), and
prints one line `cycles: ... render N.NN s` with the time of the render call alone (scene sync,
BVH build and path tracing; Blender's start-up and the image writes excluded). Blender's own status
line before it, `Fra:1 ... | Time:MM:SS.ss | ... | Finished`, is Cycles' report of the same time
(they agree to 0.01 s); bench/blender/side_by_side.sh records both.

`--calibrate` renders instead a camera looking straight at a white emitting plane of Strength 0.25 and
prints the pixel values: the check behind EMISSION_STRENGTH below. `--calibrate --backface` turns the
plane around, which must read 0 (the one-sided emission).

Coordinates. tritrace's world is x right, y down, z forward (away from the camera); Blender's is
z up. The rotation R: (x, y, z) -> (x, z, -y) (a +90 degree turn about x, determinant +1, so the
handedness and hence the image's left and right are kept) maps tritrace's camera at (0, 0, -3)
looking along +z with y down to Blender's (0, -3, 0) looking along +y with +z up. The purple wall
(x = -1) is on the image's left in both.
"""

import argparse
import math
import sys
import time

import bpy
import numpy as np

L = 555.0

# Reflectances (linear RGB), the fact sheet's.
ALBEDO = {
    "red": (0.75, 0.15, 0.15),
    "yellow": (0.75, 0.75, 0.15),
    "green": (0.15, 0.75, 0.15),
    "cyan": (0.15, 0.75, 0.75),
    "blue": (0.15, 0.15, 0.75),
    "purple": (0.75, 0.15, 0.75),
    "white": (0.75, 0.75, 0.75),
}

# tritrace's area light: radiance Le = 10 W/(m^2 sr), white, from its lower face only.
LIGHT_RADIANCE = 10.0

# Cycles' Emission shader: a surface with Emission colour C and Strength S has outgoing radiance
# C * S in every direction it emits to (no factor of pi, no area: strength is radiance, not power;
# Cycles' emission closure is `emissive_simple_eval` = 1 for any direction on either side of the
# surface, times the closure weight C * S). Checked by `--calibrate`: a camera looking straight at
# a white plane of Strength 0.25 reads 0.25 in every pixel of the linear EXR (0.25, not 1, so that
# a display transform sneaking into the file would show: sRGB would turn 0.25 into 0.537). So Strength =
# Le = 10, and the backfacing mix below keeps the upper face black, as tritrace's one-sided light.
EMISSION_STRENGTH = LIGHT_RADIANCE
CALIBRATION_STRENGTH = 0.25

# The camera: focal length = image height in pixels, so tan(vfov / 2) = 0.5.
VFOV = 2.0 * math.atan(0.5)  # 53.130 degrees


def lab_to_tritrace(v):
    """The fact sheet's scaling of a box-coordinate vertex into tritrace's world."""
    x, y, z = (c * 2.0 / L - 1.0 for c in v)
    return (-x, -y, z)


def tritrace_to_blender(p):
    """The proper rotation R: tritrace (x right, y down, z forward) -> Blender (z up)."""
    x, y, z = p
    return (x, z, -y)


def to_blender(v):
    return tritrace_to_blender(lab_to_tritrace(v))


def block_triangles(corners):
    A, B, C, D, E, F, G, H = corners
    return [(E, B, A), (E, F, B), (F, D, B), (F, H, D), (H, C, D),
            (H, G, C), (G, E, C), (E, A, C), (G, F, E), (G, H, F)]


def cornell_triangles():
    """(v0, v1, v2, colour) in the fact sheet's order, box coordinates."""
    A, B, C, D = (L, 0, 0), (0, 0, 0), (L, 0, L), (0, 0, L)
    E, F, G, H = (L, L, 0), (0, L, 0), (L, L, L), (0, L, L)
    tris = [
        (C, B, A, "green"), (C, D, B, "green"),     # floor
        (A, E, C, "purple"), (C, E, G, "purple"),   # left wall
        (F, B, D, "yellow"), (H, F, D, "yellow"),   # right wall
        (E, F, G, "cyan"), (F, H, G, "cyan"),       # ceiling
        (G, D, C, "white"), (G, H, D, "white"),     # back wall
    ]
    short = [(290, 0, 114), (130, 0, 65), (240, 0, 272), (82, 0, 225),
             (290, 165, 114), (130, 165, 65), (240, 165, 272), (82, 165, 225)]
    tall = [(423, 0, 247), (265, 0, 296), (472, 0, 406), (314, 0, 456),
            (423, 330, 247), (265, 330, 296), (472, 330, 406), (314, 330, 456)]
    tris += [(a, b, c, "red") for a, b, c in block_triangles(short)]
    tris += [(a, b, c, "blue") for a, b, c in block_triangles(tall)]
    return tris


def light_triangles():
    """The ceiling light, wound so that Blender's face normal (counter-clockwise, cross(e1, e2))
    points down to the floor: the emitting side. (tritrace's lab normal is cross(e2, e1), so
    tritrace stores the same triangles in the opposite order.)"""
    a, b, c, d = (343, 554, 227), (343, 554, 332), (213, 554, 332), (213, 554, 227)
    return [(a, b, c), (a, c, d)]


def make_mesh(name, triangles, material_slots):
    """triangles: (v0, v1, v2, slot) in Blender coordinates; one object, flat shading."""
    verts, faces, slots = [], [], []
    for v0, v1, v2, slot in triangles:
        base = len(verts)
        verts += [v0, v1, v2]
        faces.append((base, base + 1, base + 2))
        slots.append(slot)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    for mat in material_slots:
        mesh.materials.append(mat)
    for poly, slot in zip(mesh.polygons, slots):
        poly.material_index = slot
        poly.use_smooth = False
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def diffuse_material(name, rgb):
    """Lambertian: Diffuse BSDF with roughness 0 (Oren-Nayar off). Cycles shades the back of a
    face as its front, so it is two-sided like tritrace's."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*rgb, 1.0)  # scene linear, no colour transform
    bsdf.inputs["Roughness"].default_value = 0.0
    links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def emission_material(name, strength, one_sided):
    """Emission only (no BSDF: the light reflects nothing). One-sided: Strength * (1 - Backfacing),
    so a ray hitting the face from behind its normal sees black."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    emit.inputs["Strength"].default_value = strength
    if one_sided:
        geom = nodes.new("ShaderNodeNewGeometry")
        front = nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        links.new(geom.outputs["Backfacing"], front.inputs[1])
        scale = nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = strength
        links.new(front.outputs["Value"], scale.inputs[0])
        links.new(scale.outputs["Value"], emit.inputs["Strength"])
    links.new(emit.outputs["Emission"], out.inputs["Surface"])
    return mat


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    world = bpy.context.scene.world or bpy.data.worlds.new("World")
    bpy.context.scene.world = world
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)  # a missed ray is black, as in tritrace
    bg.inputs["Strength"].default_value = 0.0


def add_camera(size):
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "VERTICAL"
    cam_data.sensor_height = 32.0
    cam_data.lens = 32.0  # lens / sensor_height = 1 = f / H: tan(vfov / 2) = 0.5
    cam_data.shift_x = cam_data.shift_y = 0.0
    cam_data.clip_start = 0.01
    cam_data.clip_end = 100.0
    cam = bpy.data.objects.new("Camera", cam_data)
    # tritrace (0, 0, -3) -> Blender (0, -3, 0); Blender's camera looks along its local -z with
    # local +y up: a +90 degree turn about x makes that +y (forward) with +z (up).
    cam.location = tritrace_to_blender((0.0, 0.0, -3.0))
    cam.rotation_euler = (math.pi / 2.0, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    assert abs(cam_data.angle_y - VFOV) < 1e-6, (cam_data.angle_y, VFOV)


def build_cornell_area():
    names = list(ALBEDO)
    materials = [diffuse_material(n, ALBEDO[n]) for n in names]
    tris = [(to_blender(a), to_blender(b), to_blender(c), names.index(col))
            for a, b, c, col in cornell_triangles()]
    make_mesh("CornellBox", tris, materials)

    light = emission_material("AreaLight", EMISSION_STRENGTH, one_sided=True)
    light_tris = [(to_blender(a), to_blender(b), to_blender(c), 0) for a, b, c in light_triangles()]
    obj = make_mesh("AreaLight", light_tris, [light])
    for poly in obj.data.polygons:  # the emitting side faces the floor (Blender -z)
        assert poly.normal.z < -0.999, tuple(poly.normal)


def build_calibration(backface):
    """A white emitter of Strength CALIBRATION_STRENGTH filling the view, 1 unit in front of the
    camera, its emitting face towards the camera (or away from it with `backface`)."""
    light = emission_material("Calibration", CALIBRATION_STRENGTH, one_sided=True)
    s = 10.0
    # Blender's camera at (0, -3, 0) looks along +y; a plane at y = -2 whose normal is -y faces it.
    quad = [(-s, -2.0, -s), (s, -2.0, -s), (s, -2.0, s), (-s, -2.0, s)]
    tris = [(quad[0], quad[1], quad[2], 0), (quad[0], quad[2], quad[3], 0)]
    if backface:
        tris = [(a, c, b, m) for a, b, c, m in tris]
    obj = make_mesh("Calibration", tris, [light])
    for poly in obj.data.polygons:
        assert abs(poly.normal.y - (1.0 if backface else -1.0)) < 1e-6, tuple(poly.normal)


def configure(args):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = args.spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.use_preview_denoising = False
    cy.seed = args.seed
    cy.use_animated_seed = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0  # pixels: a sample lands uniformly in its own pixel, like tritrace's box
    cy.max_bounces = args.bounces
    cy.diffuse_bounces = args.bounces
    cy.glossy_bounces = args.bounces
    cy.transmission_bounces = args.bounces
    cy.volume_bounces = 0
    cy.transparent_max_bounces = args.bounces
    cy.sample_clamp_direct = 0.0  # no clamping
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.film_exposure = 1.0
    cy.film_transparent = False
    cy.use_auto_tile = True  # the default tiling
    scene.render.threads_mode = "FIXED"
    scene.render.threads = args.threads
    scene.render.resolution_x = args.size
    scene.render.resolution_y = args.size
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    scene.render.use_border = False
    scene.render.use_motion_blur = False
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.render.dither_intensity = 0.0
    # No colour management in the numbers: Standard view, no look, no exposure, gamma 1. (The
    # float EXR holds scene-linear values whatever the view; these only keep previews honest.)
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    scene.sequencer_colorspace_settings.name = "Linear"
    img = scene.render.image_settings
    img.file_format = "OPEN_EXR"
    img.color_depth = "32"
    img.color_mode = "RGBA"
    img.exr_codec = "ZIP"
    img.use_preview = False


def write_pfm(path, rgb):
    """rgb: H x W x 3 float32, top row first; PFM stores rows bottom-up, little-endian (scale -1)."""
    h, w, _ = rgb.shape
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


def read_back(path):
    """The written EXR's pixels as H x W x 3, top row first (Blender's buffer is bottom-up)."""
    img = bpy.data.images.load(path, check_existing=False)
    img.colorspace_settings.name = "Linear"  # raw floats, as written
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1, :, :3]


def write_exr_from(rgb, path):
    """Overwrites `path` with rgb (H x W x 3, top row first) as a float EXR through Blender."""
    h, w, _ = rgb.shape
    img = bpy.data.images.new("Average", w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Linear"
    px = np.ones((h, w, 4), dtype=np.float32)
    px[:, :, :3] = rgb[::-1]
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = path
    img.file_format = "OPEN_EXR"
    img.save()
    bpy.data.images.remove(img)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="cornell_area.py")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--out", required=True, help="output .exr (a .pfm is written beside it)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--bounces", type=int, default=128)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--passes", type=int, default=1,
                    help="diagnostic: average this many renders with consecutive seeds")
    ap.add_argument("--calibrate", action="store_true")
    ap.add_argument("--backface", action="store_true")
    args = ap.parse_args(argv)

    clear_scene()
    add_camera(args.size)
    if args.calibrate:
        build_calibration(args.backface)
    else:
        build_cornell_area()
    configure(args)

    scene = bpy.context.scene
    scene.render.filepath = args.out
    if args.passes > 1:
        # Diagnostic: `passes` renders of spp / passes samples, seeds seed, seed + 1, ..., averaged.
        # Cycles' samples are stratified (progressive multi-jittered) within one render; across
        # renders with different seeds they are independent, so --passes = --spp gives Cycles
        # with independent samples, like tritrace's sampler (for the noise comparison only: the
        # time includes a scene sync per pass).
        if args.spp % args.passes:
            sys.exit("--spp must be a multiple of --passes")
        scene.cycles.samples = args.spp // args.passes
    total = 0.0
    rgb = None
    for i in range(args.passes):
        scene.cycles.seed = args.seed + i
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        total += time.perf_counter() - t0
        bpy.data.images["Render Result"].save_render(args.out, scene=scene)
        one = read_back(args.out)
        rgb = one if rgb is None else rgb + one
    rgb = rgb / args.passes
    if args.passes > 1:
        write_exr_from(rgb, args.out)

    pfm = args.out[:-4] + ".pfm" if args.out.lower().endswith(".exr") else args.out + ".pfm"
    write_pfm(pfm, rgb)
    mean = rgb.reshape(-1, 3).mean(axis=0)
    print("cycles: %s, %dx%d, %d spp, %d bounces, %d threads: render %.2f s; mean %.5f %.5f %.5f; "
          "wrote %s and %s" % (bpy.app.version_string, args.size, args.size, args.spp,
                               args.bounces, args.threads, total, *mean, args.out, pfm))
    if args.calibrate:
        print("calibrate: white Emission of Strength %g seen from its %s: pixels min %.6f max %.6f"
              % (CALIBRATION_STRENGTH, "back" if args.backface else "front", rgb.min(), rgb.max()))


if __name__ == "__main__":
    main()
