"""Posed, clothed person meshes from the anny body model (the only module importing torch/anny).

A :class:`PersonMesh` is plain numpy in the person's local frame: feet on ``z = 0``, pelvis
above the origin, facing ``-Y`` (anny's convention), metres. The renderer places it with the
sample's ground position and rotation; the annotator projects the same vertices, so boxes
and pixels agree.

What anny gives and what we add
-------------------------------
* anny 0.6: rest pose is an A-pose; pose parameters (default ``local-ref``
  parameterisation) are rotations in world axes about each bone's head, composed down the
  kinematic chain. We build standing (arms down) and walking poses from a sagittal gait
  table (hip, knee, foot pitch, arm swing; :mod:`generator.kinematics`), not from a motion
  library.
* Clothing regions follow the skinning weights (dominant bone group) plus height cut-offs
  along each limb; garments are offset along the normals (thicker for jackets and coats),
  skirts and coats are pushed onto a cone around the pelvis axis.
* Hair is a shell over a scalp region (fixed topology for every style: vertices outside a
  style's region sit just inside the skin), plus an ellipsoid for buns and ponytails.
* Accessories (backpack, shoulder bag, handbag, cap) are boxes/ellipsoids attached to bones.

torch and anny are imported lazily (inside :class:`BodyModel`), so importing this module is
cheap; creating a :class:`BodyModel` needs ``pip install -e '.[generator]'`` and the anny
cache (built once, ~70 s; see ``generator.body.build_cache``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .kinematics import gait_angles, rot_to, rx, ry, rz
from .specs import PersonSpec

__all__ = ["BodyModel", "PersonMesh", "MATERIAL_SLOTS", "build_cache", "sphere_mesh",
           "box_mesh"]

#: Material slot names, in the order of ``PersonMesh.face_material`` indices.
MATERIAL_SLOTS = ("skin", "top", "bottom", "shoes", "eyes", "hair", "acc1", "acc2", "cap")
SKIN, TOP, BOTTOM, SHOES, EYES, HAIR = range(6)


def _import_anny():
    try:
        import anny  # noqa: F401
        import torch  # noqa: F401
    except ImportError as exc:  # pragma: no cover - exercised without the extra
        raise ImportError(
            "the person model needs torch and anny: pip install -e '.[generator]' "
            f"({exc})") from exc
    return anny, torch


def build_cache(prune: bool = False) -> list:
    """Build anny's model cache once (~70 s, ~1.7 GB RAM; honours ``ANNY_CACHE_DIR``).

    With ``prune``, delete the intermediate cache files afterwards (~780 MB): only the
    compact model file (~51 MB) is read when the cache exists. Returns the kept files.
    """
    anny, _ = _import_anny()
    from anny.paths import get_anny_cache_path

    anny.Anny()
    root = get_anny_cache_path()
    files = sorted(root.glob("v*/*.safetensors"))
    if prune:
        for f in files:
            if not f.name.startswith("build_compact_model_data_"):
                f.unlink()
        files = sorted(root.glob("v*/*.safetensors"))
    return files


# --------------------------------------------------------------------------- small meshes


def box_mesh():
    """Unit cube ``[-0.5, 0.5]^3``: (8, 3) vertices, (12, 3) triangles (outward)."""
    v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = []
    for a, b, c, d in quads:
        f += [(a, b, c), (a, c, d)]
    return v.astype(np.float64), np.array(f, dtype=np.int32)


def sphere_mesh(segments: int = 12, rings: int = 8):
    """Unit UV sphere: vertices and outward triangles (fixed topology)."""
    verts = [[0.0, 0.0, 1.0]]
    for i in range(1, rings):
        th = math.pi * i / rings
        for j in range(segments):
            ph = 2 * math.pi * j / segments
            verts.append([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph),
                          math.cos(th)])
    verts.append([0.0, 0.0, -1.0])
    faces = []
    for j in range(segments):
        faces.append((0, 1 + j, 1 + (j + 1) % segments))
    for i in range(rings - 2):
        a0 = 1 + i * segments
        b0 = a0 + segments
        for j in range(segments):
            a, a2 = a0 + j, a0 + (j + 1) % segments
            b, b2 = b0 + j, b0 + (j + 1) % segments
            faces += [(a, b, b2), (a, b2, a2)]
    last = len(verts) - 1
    base = 1 + (rings - 2) * segments
    for j in range(segments):
        faces.append((base + j, last, base + (j + 1) % segments))
    return np.array(verts), np.array(faces, dtype=np.int32)


def vertex_normals(v, f):
    """Area-weighted vertex normals, (V, 3)."""
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return n


# --------------------------------------------------------------------------- mesh


@dataclass
class PersonMesh:
    """A posed, clothed person in its local frame (numpy; see the module docstring).

    Attributes
    ----------
    vertices : (V, 3) float64
        Body vertices (13,718 for anny), clothing offsets applied.
    faces : (F, 3) int32
        Body triangles (fixed topology).
    face_material : (F,) int32
        Index into :data:`MATERIAL_SLOTS` per body triangle.
    hair_vertices : (Vh, 3), hair_faces : (Fh, 3)
        Hair shell (fixed topology; hidden parts sit inside the head).
    parts : dict
        Extra fixed-topology parts: name -> (vertices (n, 3), faces, material slot, visible).
    height : float
        Top of the head (or hair) above the ground, metres.
    """

    person_id: str
    vertices: np.ndarray
    faces: np.ndarray
    face_material: np.ndarray
    hair_vertices: np.ndarray
    hair_faces: np.ndarray
    hair_visible: bool
    parts: dict
    height: float

    def all_points(self) -> np.ndarray:
        """Every visible vertex (body, hair, parts), for silhouette boxes."""
        pts = [self.vertices]
        if self.hair_visible:
            pts.append(self.hair_vertices)
        pts += [v for (v, f, m, vis) in self.parts.values() if vis]
        return np.concatenate(pts)

    def indexed(self) -> tuple[np.ndarray, np.ndarray]:
        """Every visible part as one indexed mesh: (V, 3) vertices, (F, 3) int64 faces."""
        parts = [(self.vertices, self.faces)]
        if self.hair_visible:
            parts.append((self.hair_vertices, self.hair_faces))
        parts += [(v, f) for (v, f, m, vis) in self.parts.values() if vis]
        verts, faces, n = [], [], 0
        for v, f in parts:
            verts.append(v)
            faces.append(np.asarray(f, dtype=np.int64) + n)
            n += len(v)
        return np.concatenate(verts), np.concatenate(faces)

    def triangles(self) -> np.ndarray:
        """(T, 3, 3) every visible triangle, for masks."""
        tris = [self.vertices[self.faces]]
        if self.hair_visible:
            tris.append(self.hair_vertices[self.hair_faces])
        tris += [v[f] for (v, f, m, vis) in self.parts.values() if vis]
        return np.concatenate(tris)


_GARMENT_OFFSET = {"tshirt": 0.006, "longsleeve": 0.006, "tank": 0.004, "jacket": 0.016,
                   "coat": 0.022, "dress": 0.006, "trousers": 0.007, "shorts": 0.008,
                   "skirt": 0.006, "long_skirt": 0.006}
_SLEEVE = {"tshirt": 0.42, "longsleeve": 0.97, "tank": -0.05, "jacket": 1.0, "coat": 1.0,
           "dress": 0.3}
_LEG_COVER = {"trousers": 0.93, "shorts": 0.38, "skirt": 0.42, "long_skirt": 0.8}
# hair: (thickness m, hairline height above the eyes at [back, side, front], m)
_HAIR = {"buzz": (0.004, (-0.07, -0.01, 0.05)), "short": (0.014, (-0.07, -0.01, 0.05)),
         "medium": (0.02, (-0.11, -0.05, 0.045)), "bob": (0.026, (-0.13, -0.085, 0.045)),
         "long": (0.024, (-0.13, -0.085, 0.045)), "ponytail": (0.012, (-0.08, -0.02, 0.05)),
         "bun": (0.012, (-0.08, -0.02, 0.05)), "bald": (-0.003, (0.2, 0.2, 0.2))}


class BodyModel:
    """anny, wrapped: person spec + pose -> :class:`PersonMesh`.

    One instance per process (loading takes ~1 s with the cache built); rest shapes are
    cached per person.
    """

    def __init__(self):
        anny, torch = _import_anny()
        self._torch = torch
        torch.set_num_threads(1)
        self.model = anny.Anny()
        m = self.model
        self.bone_labels = list(m.bone_labels)
        self.bone = {name: i for i, name in enumerate(self.bone_labels)}
        self.faces = m.get_triangular_faces().cpu().numpy().astype(np.int32)
        idx = m.vertex_bone_indices.cpu().numpy()
        w = m.vertex_bone_weights.cpu().numpy()
        self.dominant_bone = idx[np.arange(len(idx)), w.argmax(1)]
        self._dtype = m.template_vertices.dtype
        self._rest_cache: dict = {}
        ref = self._rest(None)
        self._classify(ref["vertices"], ref["heads"])

    # ---------------------------------------------------------------- anny calls

    def _phenotype(self, person: PersonSpec | None) -> dict:
        if person is None:
            return {}
        p = person.phenotype
        return dict(gender=p.gender, age=p.age, muscle=p.muscle, weight=p.weight,
                    height=p.height, proportions=p.proportions)

    def _forward(self, person, pose=None):
        torch = self._torch
        with torch.no_grad():
            out = self.model(pose_parameters=pose, phenotype_kwargs=self._phenotype(person))
        return (out["vertices"][0].cpu().numpy().astype(np.float64),
                out["bone_poses"][0, :, :3, 3].cpu().numpy().astype(np.float64))

    def _rest(self, person):
        key = None if person is None else person.id
        if key not in self._rest_cache:
            v, heads = self._forward(person)
            self._rest_cache[key] = {"vertices": v, "heads": heads}
        return self._rest_cache[key]

    # ---------------------------------------------------------------- regions

    def _group_of(self, label: str) -> str:
        base = label.split(".")[0]
        if base in ("eye",):
            return "eye"
        if base in ("head",):
            return "head"
        if base.startswith("neck"):
            return "neck"
        if base.startswith(("spine", "clavicle", "shoulder")) or base in ("root",):
            return "torso"
        if base == "pelvis":
            return "pelvis"
        if base.startswith("upperarm") or base.startswith("lowerarm"):
            return "arm"
        if base.startswith(("wrist", "finger", "metacarpal")):
            return "hand"
        if base.startswith(("upperleg", "lowerleg")):
            return "leg"
        if base.startswith(("foot", "toe")):
            return "foot"
        return "torso"

    def _classify(self, v, heads):
        """Per-vertex region data from the default rest shape (topology-level, fixed)."""
        b = self.bone
        groups = np.array([self._group_of(self.bone_labels[i]) for i in self.dominant_bone])
        self.group = groups
        side = np.sign(v[:, 0])
        # arm coordinate: 0 at the shoulder joint, 1 at the wrist
        s = np.zeros(len(v))
        for sd, tag in ((1, "L"), (-1, "R")):
            a = heads[b[f"upperarm01.{tag}"]]
            w = heads[b[f"wrist.{tag}"]]
            d = w - a
            t = ((v - a) @ d) / (d @ d)
            sel = (side == sd)
            s[sel] = t[sel]
        self.arm_coord = s
        self.armpit_z = heads[b["upperarm01.L"], 2] - 0.12
        self.shoulder_x = abs(heads[b["upperarm01.L"], 0])
        # leg coordinate: 0 at the hip joint, 1 at the ankle
        zh = heads[b["upperleg01.L"], 2]
        za = heads[b["foot.L"], 2]
        self.leg_coord = (zh - v[:, 2]) / (zh - za)
        self.waist_z = heads[b["spine04"], 2] + 0.03
        self.hip_z = zh
        # head coordinates: height above the eyes, forward (-Y) offset
        eye = 0.5 * (heads[b["eye.L"]] + heads[b["eye.R"]])
        head_c = heads[b["head"]]
        self.head_h = v[:, 2] - eye[2]
        self.head_f = -(v[:, 1] - head_c[1])
        self.head_x = v[:, 0] - head_c[0]
        self.head_eye = eye
        # hair candidate region: head/neck vertices, plus the upper back for long hair
        shoulder_z = heads[b["shoulder01.L"], 2]
        back = (groups == "torso") & (v[:, 1] > heads[b["spine01"], 1] + 0.02) & \
               (v[:, 2] > shoulder_z - 0.2) & (np.abs(v[:, 0]) < 0.16)
        cand = np.isin(groups, ("head", "neck")) | back
        cand &= groups != "eye"
        self.hair_candidate = cand
        fmask = cand[self.faces].all(1)
        self.hair_face_src = self.faces[fmask]
        used = np.unique(self.hair_face_src)
        self.hair_vidx = used
        remap = -np.ones(len(v), dtype=np.int64)
        remap[used] = np.arange(len(used))
        self.hair_faces = remap[self.hair_face_src].astype(np.int32)
        self.back_region = back

    # ---------------------------------------------------------------- pose

    def pose_parameters(self, person: PersonSpec, pose: str, phase: float, jitter) -> dict:
        """anny pose parameters (bone label -> (1, 4, 4) tensor) for a pose."""
        torch = self._torch
        rest = self._rest(person)
        h = rest["heads"]
        b = self.bone
        jitter = tuple(jitter) + (0.0,) * (6 - len(tuple(jitter)))
        ps = person.pose
        if pose == "walking":
            g = gait_angles(phase, ps.stride, ps.arm_swing)
        else:
            g = {k: 0.0 for k in ("hip_L", "knee_L", "foot_L", "hip_R", "knee_R", "foot_R",
                                  "shoulder_L", "shoulder_R", "twist")}
            g["elbow_L"] = g["elbow_R"] = math.radians(ps.elbow_deg)
            g["knee_L"] = g["knee_R"] = math.radians(3)
        twist = g["twist"] + 0.5 * jitter[4]
        Wsp = rz(twist)
        Whead = rz(math.radians(ps.head_yaw_deg) + jitter[3])
        local = {"spine04": Wsp, "neck01": Wsp.T @ Whead}
        for sd, tag in ((1, "L"), (-1, "R")):
            # arms hang at the abduction angle, swing about the lateral axis
            ab = math.radians(ps.arm_abduction_deg) + 0.5 * abs(jitter[0 if tag == "L" else 1])
            down = np.array([sd * math.sin(ab), 0.0, -math.cos(ab)])
            d_ua = h[b[f"lowerarm01.{tag}"]] - h[b[f"upperarm01.{tag}"]]
            d_fa = h[b[f"wrist.{tag}"]] - h[b[f"lowerarm01.{tag}"]]
            sh = g[f"shoulder_{tag}"]
            el = g[f"elbow_{tag}"] + 0.5 * abs(jitter[2])
            Wua = Wsp @ rx(-sh) @ rot_to(d_ua, down)
            t_fa = Wsp @ rx(-(sh + el)) @ down
            Wfa = rot_to(Wua @ d_fa, t_fa) @ Wua
            local[f"upperarm01.{tag}"] = Wsp.T @ Wua
            local[f"lowerarm01.{tag}"] = Wua.T @ Wfa
            # legs: hip flexion, slight abduction (stance width), knee, foot pitch
            stance = sd * (math.radians(2.0) + 0.3 * jitter[5])
            Wth = rx(-g[f"hip_{tag}"]) @ ry(stance)
            Wsh = rx(-g[f"hip_{tag}"] + g[f"knee_{tag}"]) @ ry(stance)
            Wft = rx(g[f"foot_{tag}"])
            local[f"upperleg01.{tag}"] = Wth
            local[f"lowerleg01.{tag}"] = Wth.T @ Wsh
            local[f"foot.{tag}"] = Wsh.T @ Wft
        out = {}
        for name, R in local.items():
            T = torch.eye(4, dtype=self._dtype)[None].clone()
            T[0, :3, :3] = torch.as_tensor(R, dtype=self._dtype)
            out[name] = T
        return out

    # ---------------------------------------------------------------- build

    def build(self, person: PersonSpec, pose: str = "standing", phase: float = 0.0,
              jitter=(0.0,) * 6) -> PersonMesh:
        """The posed, clothed mesh of ``person`` (local frame, feet on the ground)."""
        rest = self._rest(person)
        rv = rest["vertices"]
        scale = person.stature / (rv[:, 2].max() - rv[:, 2].min())
        params = self.pose_parameters(person, pose, 0.0 if math.isnan(phase) else phase,
                                      jitter)
        v, heads = self._forward(person, params)
        v = v * scale
        heads = heads * scale
        f = self.faces
        n = vertex_normals(v, f)
        mat, offset = self._clothing(person)
        v = v + n * offset[:, None]
        v = self._skirt(person, v, heads, mat)
        z0 = v[:, 2].min()
        v[:, 2] -= z0
        heads[:, 2] -= z0
        face_mat = self._face_material(mat)
        hv, hair_visible = self._hair(person, v, n, scale)
        parts = self._parts(person, v, heads, scale)
        pts = [v] + ([hv] if hair_visible else []) + [p[0] for p in parts.values() if p[3]]
        height = float(np.concatenate(pts)[:, 2].max())
        return PersonMesh(person.id, v, f, face_mat, hv, self.hair_faces, hair_visible, parts,
                          height)

    def _clothing(self, person: PersonSpec):
        g = self.group
        top, bottom = person.top, person.bottom
        mat = np.full(len(g), SKIN, dtype=np.int32)
        off = np.zeros(len(g))
        sleeve = person.sleeve if person.sleeve >= 0 else _SLEEVE[top.kind]
        torso = np.isin(g, ("torso", "pelvis"))
        above = self._rest_z > self.waist_z
        # trunk
        mat[torso & above] = TOP
        mat[torso & ~above] = BOTTOM
        # arms (torso vertices count as arm only around the shoulder joint)
        shoulder = (g == "torso") & (self._rest_z > self.armpit_z) & \
                   (np.abs(self._rest_x) > self.shoulder_x - 0.04)
        arm = (g == "arm") | (shoulder & (self.arm_coord > 0.02))
        mat[arm & (self.arm_coord < sleeve)] = TOP
        if top.kind == "tank":
            mat[shoulder & (self.arm_coord > -0.05)] = SKIN
        # legs
        leg = g == "leg"
        cover = _LEG_COVER[bottom.kind]
        mat[leg & (self.leg_coord < cover)] = BOTTOM
        mat[(g == "foot") | (leg & (self.leg_coord >= 0.955))] = SHOES
        if top.kind in ("coat", "dress"):
            mat[leg & (self.leg_coord < (0.55 if top.kind == "coat" else 0.45))] = TOP
            mat[torso & ~above] = TOP
        mat[g == "eye"] = EYES
        off[mat == TOP] = _GARMENT_OFFSET[top.kind]
        off[mat == BOTTOM] = _GARMENT_OFFSET[bottom.kind]
        off[mat == SHOES] = 0.008
        return mat, off

    @property
    def _rest_z(self):
        if not hasattr(self, "_rz_cache"):
            self._rz_cache = self._rest(None)["vertices"][:, 2]
        return self._rz_cache

    def _skirt(self, person, v, heads, mat):
        """Push skirt/coat/dress hems onto a cone around the pelvis axis.

        Each thigh's vertices are spread over half of the cone by their angle around the
        thigh (outer side -> the hip, inner side -> front/back centre), so the two legs
        close into one surface.
        """
        kind_top, kind_bottom = person.top.kind, person.bottom.kind
        if kind_top in ("coat", "dress"):
            length, flare, slot = (0.55, 0.12, TOP) if kind_top == "coat" else (0.45, 0.18, TOP)
        elif kind_bottom in ("skirt", "long_skirt"):
            length = _LEG_COVER[kind_bottom]
            flare, slot = (0.2, BOTTOM) if kind_bottom == "skirt" else (0.1, BOTTOM)
        else:
            return v
        b = self.bone
        zh = 0.5 * (heads[b["upperleg01.L"], 2] + heads[b["upperleg01.R"], 2])
        cx, cy = heads[b["root"], 0], heads[b["root"], 1]
        legs = (self.group == "leg") & (self.leg_coord < length) & (mat == slot)
        trunk = np.isin(self.group, ("pelvis", "torso")) & (v[:, 2] < zh + 0.02) & (mat == slot)
        sel = legs | trunk
        if not sel.any():
            return v
        band = np.isin(self.group, ("pelvis", "torso")) & (np.abs(v[:, 2] - zh) < 0.04)
        rx = max(np.abs(v[band, 0] - cx).max(), 0.1) if band.any() else 0.17
        ry = max(np.abs(v[band, 1] - cy).max(), 0.08) if band.any() else 0.12
        a = np.arctan2(v[:, 1] - cy, v[:, 0] - cx)
        for sd, tag in ((1.0, "L"), (-1.0, "R")):
            hip = heads[b[f"upperleg01.{tag}"]]
            knee = heads[b[f"lowerleg01.{tag}"]]
            leg = legs & (np.sign(self._rest_x) == sd)
            if not leg.any():
                continue
            u = np.clip((hip[2] - v[leg, 2]) / max(hip[2] - knee[2], 1e-6), 0, 1)
            axis = hip[None, :2] + u[:, None] * (knee - hip)[None, :2]
            dx = sd * (v[leg, 0] - axis[:, 0])
            dy = v[leg, 1] - axis[:, 1]
            theta = np.arctan2(dy, dx)                     # 0 = outer side of the thigh
            a[leg] = theta / 2 if sd > 0 else np.pi - theta / 2
        a = a[sel]
        ca, sa = np.cos(a), np.sin(a)
        # how far the body reaches along the (remapped) direction: a leg swinging forward
        # pushes the skirt forward with it
        reach = (v[sel, 0] - cx) * ca + (v[sel, 1] - cy) * sa
        r_ell = rx * ry / np.sqrt((ry * ca) ** 2 + (rx * sa) ** 2)
        drop = np.maximum(zh - v[sel, 2], 0.0)
        r = np.maximum(r_ell + 0.01 + drop * flare, reach + 0.006)
        out = v.copy()
        out[sel, 0] = cx + r * ca
        out[sel, 1] = cy + r * sa
        return out

    @property
    def _rest_x(self):
        if not hasattr(self, "_rx_cache"):
            self._rx_cache = self._rest(None)["vertices"][:, 0]
        return self._rx_cache

    def _face_material(self, mat):
        fm = mat[self.faces]
        # majority vote per triangle, ties -> first vertex
        out = fm[:, 0].copy()
        same12 = fm[:, 1] == fm[:, 2]
        out[same12] = fm[same12, 1]
        return out.astype(np.int32)

    def _hair(self, person, v, n, scale):
        style = person.hair.style
        thick, (t_back, t_side, t_front) = _HAIR[style]
        idx = self.hair_vidx
        h = self.head_h[idx]
        fwd = self.head_f[idx]
        thr = np.interp(fwd, [-0.12, -0.05, 0.0, 0.05, 0.12],
                        [t_back, t_side, t_side, t_front, t_front])
        inside = h > thr
        t = np.full(len(idx), -0.003)
        if thick > 0:
            taper = np.clip((h - thr) / 0.03, 0.0, 1.0)
            top = np.clip(0.6 + 0.4 * h / 0.1, 0.4, 1.3)
            t = np.where(inside, 0.001 + thick * person.hair.volume * top * taper, -0.003)
            if style == "long":
                back = self.back_region[idx]
                t = np.where(back, 0.02 * person.hair.volume, t)
        hv = v[idx] + n[idx] * t[:, None]
        return hv, bool(thick > 0)

    def _parts(self, person, v, heads, scale):
        b = self.bone
        sv, sf = sphere_mesh()
        bv, bf = box_mesh()
        parts = {}
        head = heads[b["head"]]
        head_pts = v[self.group == "head"]
        top_z = head_pts[:, 2].max()
        hw = np.ptp(head_pts[:, 0]) / 2
        hd = np.ptp(head_pts[:, 1]) / 2
        back_y = head_pts[:, 1].max()
        style = person.hair.style
        # bun / ponytail: an ellipsoid at the back of the head
        if style == "bun":
            c = np.array([head[0], back_y + 0.01, top_z - 0.06])
            ext = np.array([0.05, 0.05, 0.05]) * person.hair.volume
        else:
            c = np.array([head[0], back_y + 0.015, top_z - 0.2])
            ext = np.array([0.035, 0.03, 0.11]) * person.hair.volume
        parts["hair_extra"] = (sv * ext + c, sf, HAIR, style in ("bun", "ponytail"))
        acc = dict(person.accessories)
        # cap: a flattened ellipsoid over the crown
        cap_c = np.array([head[0], head[1] - 0.01, top_z - 0.035])
        cap_e = np.array([hw + 0.012, hd + 0.018, 0.06])
        parts["cap"] = (sv * cap_e + cap_c, sf, 8, "cap" in acc)
        # backpack behind the upper back
        sp = heads[b["spine02"]]
        torso = v[(self.group == "torso") & (np.abs(v[:, 2] - sp[2] - 0.1) < 0.12)]
        back = torso[:, 1].max() if len(torso) else sp[1] + 0.12
        size = np.array([0.30, 0.15, 0.40]) * min(1.1, max(0.85, scale))
        c = np.array([sp[0], back + size[1] / 2 + 0.005, sp[2] + 0.1])
        parts["backpack"] = (bv * size + c, bf, 6, "backpack" in acc)
        # shoulder bag at the right hip, handbag below the right wrist
        hip = heads[b["upperleg01.R"]]
        wr = heads[b["wrist.R"]]
        if "shoulder_bag" in acc:
            size = np.array([0.08, 0.28, 0.24])
            c = np.array([hip[0] - 0.14, hip[1] + 0.02, hip[2] + 0.02])
            parts["bag"] = (bv * size + c, bf, 7, True)
        else:
            size = np.array([0.08, 0.24, 0.2])
            c = np.array([wr[0] - 0.02, wr[1], wr[2] - 0.14])
            parts["bag"] = (bv * size + c, bf, 7, "handbag" in acc)
        return parts
