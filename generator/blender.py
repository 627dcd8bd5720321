"""The Blender/Cycles renderer: the only module of the generator that imports ``bpy``.

It translates what :mod:`generator.sampling`, :mod:`generator.layout` and
:mod:`generator.body` computed in numpy -- primitives, person meshes, lights, cameras -- into
a Blender scene and renders it. It decides nothing about geometry; the values it sets
(settings, camera parameters, sun orientation, meshes' arrays, poses, colours) come from
:mod:`generator.blendparams`, which also documents the camera conversion.

Memory: person meshes have a fixed topology and are updated in place
(``foreach_set``), materials are created once per slot and only their node values change;
scene meshes are rebuilt only when the scene changes.
"""

from __future__ import annotations

import math
import sys as _sys

import numpy as np

from viewadapt.io.files import atomic_path

from .png import strip_png_metadata

# A process started by one that had imported bpy (multiprocessing/Dask workers inherit
# sys.path) sees Blender's scripts/modules/bpy before the real module; drop those entries
# so that `import bpy` finds the compiled module (which adds them back itself).
if "bpy" not in _sys.modules:
    _sys.path[:] = [p for p in _sys.path
                    if not (("/bpy/" in p or "\\bpy\\" in p) and "scripts" in p)]

try:
    import bpy
    from mathutils import Matrix
except ImportError as exc:  # pragma: no cover - exercised where bpy is missing
    raise ImportError(
        "generator.blender needs Blender's Python module (bpy 5.0, Python 3.11): "
        f"pip install -e '.[generator]' ({exc})") from exc

from .blendparams import (
    GARMENT_PATTERNS, OUTSIDE_MATERIAL, camera_to_blender, garment_params, mesh_arrays,
    pattern_texture, person_pose, person_roughness, scene_parts, scene_settings, slot_colors,
    sun_matrix,
)
from .body import MATERIAL_SLOTS, PersonMesh, sphere_mesh
from .layout import SceneLayout
from .specs import MaterialSpec, PersonSpec

__all__ = ["BlenderRenderer", "blender_version"]


def blender_version() -> str:
    return bpy.app.version_string


# --------------------------------------------------------------------------- node helpers


def _sock(sockets, identifier):
    for s in sockets:
        if s.identifier == identifier:
            return s
    raise KeyError(identifier)


def _new_material(name: str):
    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    nt.nodes.clear()
    return mat, nt


def _mix_rgb(nt, fac, a, b):
    m = nt.nodes.new("ShaderNodeMix")
    m.data_type = "RGBA"
    m.clamp_factor = True
    link = nt.links.new
    if isinstance(fac, (int, float)):
        _sock(m.inputs, "Factor_Float").default_value = fac
    else:
        link(fac, _sock(m.inputs, "Factor_Float"))
    for ident, v in (("A_Color", a), ("B_Color", b)):
        if isinstance(v, (tuple, list)):
            _sock(m.inputs, ident).default_value = (*v[:3], 1.0)
        else:
            link(v, _sock(m.inputs, ident))
    return _sock(m.outputs, "Result_Color")


def _math(nt, op, a, b=None, c=None, clamp=False):
    n = nt.nodes.new("ShaderNodeMath")
    n.operation = op
    n.use_clamp = clamp
    for i, v in enumerate((a, b, c)):
        if v is None:
            continue
        if isinstance(v, (int, float)):
            n.inputs[i].default_value = v
        else:
            nt.links.new(v, n.inputs[i])
    return n.outputs[0]


def _cutaway_output(nt, shader_out):
    """Back faces are transparent to camera rays (cut-away rooms); shadows unaffected."""
    lp = nt.nodes.new("ShaderNodeLightPath")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    fac = _math(nt, "MULTIPLY", lp.outputs["Is Camera Ray"], geo.outputs["Backfacing"])
    tr = nt.nodes.new("ShaderNodeBsdfTransparent")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(fac, mix.inputs[0])
    nt.links.new(shader_out, mix.inputs[1])
    nt.links.new(tr.outputs[0], mix.inputs[2])
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(mix.outputs[0], out.inputs["Surface"])


def build_scene_material(spec: MaterialSpec, name: str):
    """A procedural scene material from its spec (UVs are world metres)."""
    mat, nt = _new_material(name)
    link = nt.links.new
    tc = nt.nodes.new("ShaderNodeTexCoord")
    uv = tc.outputs["UV"]
    c = spec.colors
    fac = None
    color = None
    p = spec.pattern
    tex = pattern_texture(spec)
    if tex is None:
        color = c[0]
    else:
        n = nt.nodes.new(tex["node"])
        link(uv, n.inputs["Vector"])
        for key, value in tex["props"].items():
            setattr(n, key, value)
        for key, value in tex["inputs"].items():
            n.inputs[key].default_value = value
        if p in ("brick", "tiles", "checker"):
            color = n.outputs["Color"]
            fac = n.outputs["Fac"]
        elif p == "noise":
            fac = n.outputs["Fac"]
            stretched = _math(nt, "MULTIPLY_ADD", fac, 2.2, -0.6)
            color = _mix_rgb(nt, stretched, c[0], c[1])
        elif p == "voronoi":
            sep = nt.nodes.new("ShaderNodeSeparateColor")
            link(n.outputs["Color"], sep.inputs[0])
            fac = sep.outputs[0]
            color = _mix_rgb(nt, fac, c[0], c[1])
        else:                                       # wave, stripes
            fac = n.outputs["Fac"]
            if p == "stripes":
                fac = _math(nt, "GREATER_THAN", fac, 0.5)
            color = _mix_rgb(nt, fac, c[0], c[1])
    if spec.hue_jitter > 0 or spec.value_jitter > 0:
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = "prim_rand"
        r = attr.outputs["Fac"]
        hsv = nt.nodes.new("ShaderNodeHueSaturation")
        link(_math(nt, "MULTIPLY_ADD", r, 2 * spec.hue_jitter, 0.5 - spec.hue_jitter),
             hsv.inputs["Hue"])
        r2 = _math(nt, "FRACT", _math(nt, "MULTIPLY", r, 7.31))
        link(_math(nt, "MULTIPLY_ADD", r2, 2 * spec.value_jitter, 1.0 - spec.value_jitter),
             hsv.inputs["Value"])
        if isinstance(color, tuple):
            hsv.inputs["Color"].default_value = (*color, 1)
        else:
            link(color, hsv.inputs["Color"])
        color = hsv.outputs["Color"]
    bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
    if isinstance(color, tuple):
        bsdf.inputs["Base Color"].default_value = (*color, 1)
    else:
        link(color, bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = spec.roughness
    bsdf.inputs["Metallic"].default_value = spec.metallic
    if spec.emission > 0:
        bsdf.inputs["Emission Strength"].default_value = spec.emission
        if isinstance(color, tuple):
            bsdf.inputs["Emission Color"].default_value = (*color, 1)
        else:
            link(color, bsdf.inputs["Emission Color"])
    if spec.bump > 0 and fac is not None:
        bump = nt.nodes.new("ShaderNodeBump")
        bump.inputs["Strength"].default_value = spec.bump
        bump.inputs["Distance"].default_value = 0.01
        link(fac, bump.inputs["Height"])
        link(bump.outputs["Normal"], bsdf.inputs["Normal"])
    _cutaway_output(nt, bsdf.outputs["BSDF"])
    return mat


# --------------------------------------------------------------------------- geometry


def _mesh_from_triangles(name, verts, tris, *, face_rand=None, sharp=None, uv=True):
    """A Blender mesh from numpy triangles (with world-metre UVs and attributes)."""
    arr = mesh_arrays(verts, tris, face_rand=face_rand, sharp=sharp, uv=uv)
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", arr["co"])
    me.loops.add(3 * len(tris))
    me.loops.foreach_set("vertex_index", arr["vertex_index"])
    me.polygons.add(len(tris))
    me.polygons.foreach_set("loop_start", arr["loop_start"])
    me.update(calc_edges=True)
    if uv:
        me.uv_layers.new(name="UVMap").data.foreach_set("uv", arr["uv"])
    if face_rand is not None:
        a = me.attributes.new("prim_rand", "FLOAT", "FACE")
        a.data.foreach_set("value", arr["prim_rand"])
    if sharp is not None:
        a = me.attributes.get("sharp_face") or me.attributes.new("sharp_face", "BOOLEAN", "FACE")
        a.data.foreach_set("value", arr["sharp_face"])
    me.validate(clean_customdata=False)
    return me


class BlenderRenderer:
    """One Blender scene reused for every render of a process.

    Parameters
    ----------
    threads : int
        Cycles CPU threads.
    n_slots : int
        Person slots (persons in one image at most).
    light_tree, fast_gi, max_bounces, denoise : Cycles settings.
    """

    def __init__(self, *, threads: int = 0, n_slots: int = 6, light_tree: bool = False,
                 fast_gi: bool = True, max_bounces: int = 4, denoise: bool = True):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        sc = bpy.context.scene
        self.scene = sc
        for attr, value in scene_settings(threads=threads, light_tree=light_tree,
                                          fast_gi=fast_gi, max_bounces=max_bounces,
                                          denoise=denoise):
            *head, name = attr.split(".")
            obj = sc
            for h in head:
                obj = getattr(obj, h)
            setattr(obj, name, value)
        self.samples = 16
        self._scene_objects: list = []
        self._scene_id = None
        self._make_world()
        self._make_camera()
        self._make_sun()
        self._area_lights: list = []
        self.slots = [self._make_slot(k) for k in range(n_slots)]

    # ---------------------------------------------------------------- fixed parts

    def _make_world(self):
        w = bpy.data.worlds.new("world")
        self.scene.world = w
        # Automatic importance maps are rebuilt per render at 1024 px (~0.6 s each)
        w.cycles.sampling_method = "MANUAL"
        w.cycles.sample_map_resolution = 32
        nt = w.node_tree
        nt.nodes.clear()
        tc = nt.nodes.new("ShaderNodeTexCoord")
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        nt.links.new(tc.outputs["Generated"], sep.inputs[0])
        fac = _math(nt, "POWER", _math(nt, "MAXIMUM", sep.outputs["Z"], 0.0), 0.6)
        mix = nt.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        nt.links.new(fac, _sock(mix.inputs, "Factor_Float"))
        bg = nt.nodes.new("ShaderNodeBackground")
        nt.links.new(_sock(mix.outputs, "Result_Color"), bg.inputs["Color"])
        out = nt.nodes.new("ShaderNodeOutputWorld")
        nt.links.new(bg.outputs[0], out.inputs["Surface"])
        self._world_mix = mix
        self._world_bg = bg

    def _make_camera(self):
        cd = bpy.data.cameras.new("camera")
        cd.sensor_fit = "HORIZONTAL"
        cd.clip_start = 0.05
        cd.clip_end = 2000.0
        ob = bpy.data.objects.new("camera", cd)
        self.scene.collection.objects.link(ob)
        self.scene.camera = ob
        self.camera = ob

    def _make_sun(self):
        ld = bpy.data.lights.new("sun", "SUN")
        ob = bpy.data.objects.new("sun", ld)
        self.scene.collection.objects.link(ob)
        self.sun = ob

    def _make_slot(self, k: int) -> dict:
        """Objects and materials of person slot ``k`` (created once, updated in place)."""
        root = bpy.data.objects.new(f"person{k}", None)
        self.scene.collection.objects.link(root)
        mats = {name: self._person_material(f"p{k}_{name}", name) for name in MATERIAL_SLOTS}
        slot = {"root": root, "mats": mats, "objects": {}, "body_mesh": None}
        return slot

    def _person_material(self, name: str, role: str):
        mat, nt = _new_material(name)
        link = nt.links.new
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        link(bsdf.outputs[0], out.inputs["Surface"])
        nodes = {"bsdf": bsdf}
        bsdf.inputs["Roughness"].default_value = person_roughness(role)
        if role in ("top", "bottom"):
            # colour = mix(color1, color2, pattern), pattern = sum of weighted textures in
            # the person's local (object) coordinates divided by the pattern scale
            tc = nt.nodes.new("ShaderNodeTexCoord")
            scale = nt.nodes.new("ShaderNodeValue")
            vec = nt.nodes.new("ShaderNodeVectorMath")
            vec.operation = "DIVIDE"
            link(tc.outputs["Object"], vec.inputs[0])
            comb = nt.nodes.new("ShaderNodeCombineXYZ")
            for i in range(3):
                link(scale.outputs[0], comb.inputs[i])
            link(comb.outputs[0], vec.inputs[1])
            v = vec.outputs[0]
            wave = nt.nodes.new("ShaderNodeTexWave")
            wave.bands_direction = "Z"
            wave.inputs["Scale"].default_value = 1.0
            wave.inputs["Distortion"].default_value = 0.0
            wave.inputs["Detail"].default_value = 0.0
            link(v, wave.inputs["Vector"])
            stripes = _math(nt, "GREATER_THAN", wave.outputs["Fac"], 0.5)
            checker = nt.nodes.new("ShaderNodeTexChecker")
            checker.inputs["Scale"].default_value = 1.0
            link(v, checker.inputs["Vector"])
            noise = nt.nodes.new("ShaderNodeTexNoise")
            noise.inputs["Scale"].default_value = 1.0
            noise.inputs["Detail"].default_value = 4.0
            link(v, noise.inputs["Vector"])
            noise_f = _math(nt, "MULTIPLY_ADD", noise.outputs["Fac"], 2.5, -0.75, clamp=True)
            vor = nt.nodes.new("ShaderNodeTexVoronoi")
            vor.inputs["Scale"].default_value = 1.0
            link(v, vor.inputs["Vector"])
            dots = _math(nt, "LESS_THAN", vor.outputs["Distance"], 0.3)
            weights = {}
            total = None
            for key, f in zip(GARMENT_PATTERNS,
                              (stripes, checker.outputs["Fac"], noise_f, dots)):
                wv = nt.nodes.new("ShaderNodeValue")
                weights[key] = wv
                term = _math(nt, "MULTIPLY", f, wv.outputs[0])
                total = term if total is None else _math(nt, "ADD", total, term)
            c1 = nt.nodes.new("ShaderNodeRGB")
            c2 = nt.nodes.new("ShaderNodeRGB")
            col = _mix_rgb(nt, _math(nt, "MINIMUM", total, 1.0), c1.outputs[0], c2.outputs[0])
            link(col, bsdf.inputs["Base Color"])
            nodes.update(scale=scale, weights=weights, c1=c1, c2=c2)
            bsdf.inputs["Sheen Weight"].default_value = 0.3
        return {"mat": mat, "nodes": nodes}

    # ---------------------------------------------------------------- scene

    def load_scene(self, layout: SceneLayout) -> None:
        """Build a scene's static geometry and materials (no-op if already loaded)."""
        spec = layout.spec
        if self._scene_id == spec.id:
            return
        self._clear_scene()
        mats = {name: build_scene_material(m, f"{spec.id}_{name}")
                for name, m in spec.materials.items()}
        objs = []

        def add_object(name, me, mat):
            me.materials.append(mat)
            ob = bpy.data.objects.new(name, me)
            self.scene.collection.objects.link(ob)
            objs.append(ob)
            return ob

        # ground, room shell and the neutral ground around it, objects
        for obname, mename, v, f, mname, rand, sharp in scene_parts(layout):
            if mname not in mats:          # "__outside"
                mats[mname] = build_scene_material(OUTSIDE_MATERIAL, f"{spec.id}{mname}")
            me = _mesh_from_triangles(mename, v, f, face_rand=rand, sharp=sharp)
            add_object(obname, me, mats[mname])
        for i, a in enumerate(spec.lighting.area_lights):
            ld = bpy.data.lights.new(f"area{i}", "AREA")
            ld.shape = "RECTANGLE"
            ld.size, ld.size_y = a.size
            ob = bpy.data.objects.new(f"area{i}", ld)
            ob.location = a.position          # points down (-Z) by default
            ob.visible_camera = False
            self.scene.collection.objects.link(ob)
            objs.append(ob)
            self._area_lights.append(ob)
        self._scene_objects = objs
        self._scene_materials = list(mats.values())
        self._scene_id = spec.id
        self.sun.hide_render = spec.lighting.sun is None

    def _clear_scene(self):
        for ob in self._scene_objects:
            data = ob.data
            bpy.data.objects.remove(ob, do_unlink=True)
            if isinstance(data, bpy.types.Mesh):
                bpy.data.meshes.remove(data)
            elif isinstance(data, bpy.types.Light):
                bpy.data.lights.remove(data)
        for m in getattr(self, "_scene_materials", []):
            bpy.data.materials.remove(m)
        self._scene_objects = []
        self._scene_materials = []
        self._area_lights = []
        self._scene_id = None

    # ---------------------------------------------------------------- lighting

    def set_lighting(self, lighting) -> None:
        """Apply a :class:`generator.sampling.Lighting` draw."""
        if not math.isnan(lighting.sun_elevation) and lighting.sun_strength > 0:
            M = sun_matrix(lighting.sun_elevation, lighting.sun_azimuth)
            self.sun.matrix_world = Matrix(M.tolist())
            self.sun.data.energy = lighting.sun_strength
            self.sun.data.color = lighting.sun_color
            self.sun.data.angle = lighting.sun_angle
            self.sun.hide_render = False
        else:
            self.sun.hide_render = True
        _sock(self._world_mix.inputs, "A_Color").default_value = (*lighting.sky_horizon, 1)
        _sock(self._world_mix.inputs, "B_Color").default_value = (*lighting.sky_zenith, 1)
        self._world_bg.inputs["Strength"].default_value = lighting.sky_strength
        for ob, s, c in zip(self._area_lights, lighting.area_strengths, lighting.area_colors):
            ob.data.energy = s
            ob.data.color = c
        self.scene.view_settings.exposure = lighting.exposure

    # ---------------------------------------------------------------- persons

    def _ensure_slot_objects(self, slot: dict, mesh: PersonMesh, k: int):
        objs = slot["objects"]
        if "body" not in objs:
            m = slot["mats"]
            me = _mesh_from_triangles(f"p{k}_body", mesh.vertices, mesh.faces, uv=False)
            for name in MATERIAL_SLOTS:
                me.materials.append(m[name]["mat"])
            me.shade_smooth()
            ob = bpy.data.objects.new(f"p{k}_body", me)
            self.scene.collection.objects.link(ob)
            ob.parent = slot["root"]
            objs["body"] = ob
            me = _mesh_from_triangles(f"p{k}_hair", mesh.hair_vertices, mesh.hair_faces,
                                      uv=False)
            me.materials.append(m["hair"]["mat"])
            me.shade_smooth()
            ob = bpy.data.objects.new(f"p{k}_hair", me)
            self.scene.collection.objects.link(ob)
            ob.parent = slot["root"]
            objs["hair"] = ob
            for name, (pv, pf, mslot, vis) in mesh.parts.items():
                me = _mesh_from_triangles(f"p{k}_{name}", pv, pf, uv=False)
                me.materials.append(m[MATERIAL_SLOTS[mslot]]["mat"])
                if name in ("hair_extra", "cap"):
                    me.shade_smooth()
                ob = bpy.data.objects.new(f"p{k}_{name}", me)
                self.scene.collection.objects.link(ob)
                ob.parent = slot["root"]
                objs[name] = ob

    @staticmethod
    def _set_verts(ob, verts):
        me = ob.data
        me.vertices.foreach_set("co", np.asarray(verts, dtype=np.float32).ravel())
        me.update()

    def _set_colors(self, slot: dict, person: PersonSpec):
        m = slot["mats"]
        for name, color in slot_colors(person).items():
            m[name]["nodes"]["bsdf"].inputs["Base Color"].default_value = (*color, 1)
        for name, g in garment_params(person).items():
            nodes = m[name]["nodes"]
            nodes["c1"].outputs[0].default_value = (*g["color"], 1)
            nodes["c2"].outputs[0].default_value = (*g["color2"], 1)
            nodes["scale"].outputs[0].default_value = g["scale"]
            for key, wv in nodes["weights"].items():
                wv.outputs[0].default_value = g["weights"][key]

    def set_persons(self, persons) -> None:
        """Place persons: a list of ``(PersonMesh, PersonSpec, ground_xy, rotation)``."""
        if len(persons) > len(self.slots):
            raise ValueError(f"{len(persons)} persons but only {len(self.slots)} slots")
        for k, slot in enumerate(self.slots):
            if k >= len(persons):
                for ob in slot["objects"].values():
                    ob.hide_render = True
                continue
            mesh, person, xy, rot = persons[k]
            self._ensure_slot_objects(slot, mesh, k)
            objs = slot["objects"]
            self._set_verts(objs["body"], mesh.vertices)
            objs["body"].data.polygons.foreach_set("material_index", mesh.face_material)
            objs["body"].data.update()
            self._set_verts(objs["hair"], mesh.hair_vertices)
            objs["body"].hide_render = False
            objs["hair"].hide_render = not mesh.hair_visible
            for name, (pv, pf, mslot, vis) in mesh.parts.items():
                self._set_verts(objs[name], pv)
                objs[name].hide_render = not vis
            self._set_colors(slot, person)
            slot["root"].matrix_world = Matrix(person_pose(xy, rot).tolist())

    # ---------------------------------------------------------------- test helpers

    def set_scene_visible(self, visible: bool) -> None:
        """Show or hide the scene geometry (ground, shell, objects); persons unaffected."""
        for ob in self._scene_objects:
            ob.hide_render = not visible

    def set_dark(self) -> None:
        """No sun, black sky, area lights off (for calibration renders)."""
        self.sun.hide_render = True
        self._world_bg.inputs["Strength"].default_value = 0.0
        for ob in self._area_lights:
            ob.data.energy = 0.0
        self.scene.view_settings.exposure = 0.0

    def add_marker(self, center, radius: float, strength: float = 10.0):
        """An emissive sphere at ``center`` (world metres); returns a handle for removal."""
        v, f = sphere_mesh(32, 16)
        me = _mesh_from_triangles("marker", np.asarray(v) * radius + np.asarray(center), f,
                                  uv=False)
        mat, nt = _new_material("marker")
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Strength"].default_value = strength
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        nt.links.new(em.outputs[0], out.inputs["Surface"])
        me.materials.append(mat)
        ob = bpy.data.objects.new("marker", me)
        self.scene.collection.objects.link(ob)
        return ob

    def remove_marker(self, ob) -> None:
        me = ob.data
        mats = list(me.materials)
        bpy.data.objects.remove(ob, do_unlink=True)
        bpy.data.meshes.remove(me)
        for m in mats:
            bpy.data.materials.remove(m)

    # ---------------------------------------------------------------- camera & render

    def set_camera(self, K, R, t, width: int, height: int, supersample: int = 1) -> None:
        p = camera_to_blender(K, R, t, width, height)
        cam = self.camera
        cam.matrix_world = Matrix(p["matrix_world"].tolist())
        cd = cam.data
        cd.sensor_fit = "HORIZONTAL"
        cd.sensor_width = p["sensor_width"]
        cd.lens = p["lens"]
        cd.shift_x = p["shift_x"]
        cd.shift_y = p["shift_y"]
        r = self.scene.render
        r.resolution_x = width * supersample
        r.resolution_y = height * supersample
        r.pixel_aspect_x = 1.0
        r.pixel_aspect_y = float(p["pixel_aspect"]) if abs(p["pixel_aspect"] - 1) > 1e-9 else 1.0
        self._size = (width, height, supersample)

    def render(self, path, *, samples: int, seed: int, transparent: bool = False) -> None:
        """Render to ``path`` (PNG) atomically (:func:`viewadapt.io.files.atomic_path`)."""
        sc = self.scene
        sc.cycles.samples = int(samples)
        sc.cycles.seed = int(seed) % (2 ** 31 - 1)
        sc.render.film_transparent = transparent
        sc.render.image_settings.color_mode = "RGBA" if transparent else "RGB"
        width, height, ss = self._size
        with atomic_path(path, suffix=".png") as tmp:
            sc.render.filepath = str(tmp)
            bpy.ops.render.render(write_still=True)
            # Blender writes the date and render time into the file: drop those chunks so
            # the bytes depend on the pixels only (generator.png)
            stripped = strip_png_metadata(tmp.read_bytes())
            if stripped is not None:
                tmp.write_bytes(stripped)
            if ss > 1:
                import cv2

                img = cv2.imread(str(tmp), cv2.IMREAD_UNCHANGED)
                img = cv2.resize(img, (width, height), interpolation=cv2.INTER_AREA)
                ok, buf = cv2.imencode(".png", img)
                if not ok:  # pragma: no cover
                    raise RuntimeError(f"could not encode {path}")
                with open(tmp, "wb") as fh:
                    fh.write(buf.tobytes())
