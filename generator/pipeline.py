"""Run a dataset plan: workers render work units, the manifest is assembled from their parts.

Execution engines:

* a local process pool (default; ``jobs`` spawned workers, each with its own Blender and
  anny, ``threads = cores // jobs`` Cycles threads each) -- the main process never imports
  bpy or torch;
* a Dask distributed cluster (``scheduler="tcp://host:port"``), the same unit function;
* inline (``jobs=0``; in this process -- used by tests and the benchmark).

``shard=(i, n)`` renders only the i-th of n contiguous blocks of units (job arrays); the
manifest always covers every finished unit of the whole plan, so the last shard to finish
(or a plain rerun) writes the complete manifest.

Resuming (:mod:`generator.resume`): a unit whose part file exists and whose files all pass
a full check (:func:`generator.png.png_problem`; depth maps read back) is skipped, a bad
file is removed and rendered again; inside an unfinished unit every sound image already on
disk is kept and only the rest is rendered; a larger ``frames`` or
``backgrounds_per_scene`` extends a finished set. Person crops also get a depth map of the
posed body (``depth/``, numpy, no rendering): a dataset rendered before depth maps existed
gets them from a rerun, without re-rendering.

Camera effects (``config.camera_effects``, :mod:`generator.camera_effects`): with them on,
every image is rendered to a hidden raw file, passed through its own draw of the effects
(seeded from its sample's seed and its path) and written; the draw is recorded in the
manifest row's ``camera_effects`` (and, for frames, in ``frames_coco.json``).
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from viewadapt.geometry import Camera, window_to_image_homography, window_to_plane
from viewadapt.io.bounded import MAX_INPUT_BYTES, check_json_depth, read_limited_text
from viewadapt.io.files import UserError, atomic_write_text, check_output_dir, write_marker
from viewadapt.io.locks import hold_output_dir
from viewadapt.surface import surface_depth

from .camera_effects import (
    NO_EFFECTS, draw_image_effects, effects_json, raw_render_path, render_with_effects,
)
from .contents import (
    dataset_metadata, depth_relpath, planned_paths, unit_depth_paths, unit_paths,
)
from .layout import layout_scene
from .manifest import (
    assemble_manifest, content_hash, json_matrix, part_path, write_depth, write_part,
)
from .resume import check_depth, check_image, check_resumable, interrupted, pending_units
from .sampling import (
    GeneratorConfig, WorkUnit, derive_seed, image_relpath, plan_dataset, select_shard,
)
from .specs import default_roster_path, default_scene_dir, load_roster, load_scenes

__all__ = ["generate", "GenerateResult", "run_unit", "planned_paths", "dataset_metadata",
           "depth_relpath", "unit_paths", "unit_depth_paths", "STATE", "worker_state",
           "scene_layout", "cpu_count", "unit_person_ids"]


@dataclass
class GenerateResult:
    out: Path
    n_units: int
    n_units_run: int
    n_images: int
    n_rendered: int
    n_kept: int
    seconds: float
    complete: bool
    #: kept files found truncated or corrupt and rendered again
    n_repaired: int = 0

    def summary(self) -> str:
        rate = self.n_rendered / self.seconds if self.seconds > 0 else float("nan")
        state = "complete" if self.complete else "INCOMPLETE (other shards or units pending)"
        fixed = (f" ({self.n_repaired} of them replacing truncated or corrupt files)"
                 if self.n_repaired else "")
        return (f"{self.out}: {self.n_images} images in plan; rendered {self.n_rendered}"
                f"{fixed}, kept {self.n_kept} in {self.seconds:.1f} s ({rate:.2f} images/s); "
                f"dataset {state}")


# --------------------------------------------------------------------------- worker

#: This process's worker state: ``threads``, the ``body`` model, the ``renderer`` (and its
#: version and settings ``key``), scene ``layouts``. Shared with :mod:`generator.bench` and
#: the tests, which drive a renderer in-process.
STATE: dict = {}


def _worker_init(threads: int, quiet: bool = True) -> None:
    """Per-process set-up of a pool worker: Cycles threads, silence Blender's stdout."""
    STATE["threads"] = threads
    if quiet:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)


def worker_state(config: GeneratorConfig, threads: int):
    """This process's ``(body model, renderer)`` for ``config``, made on first use (and
    remade when the renderer or its settings change)."""
    n_slots = max(1, config.persons_per_frame[1])
    # everything the renderer is made with (a renderer with too few person slots or another
    # supersampling must not be reused by a later config in the same process)
    key = (config.renderer, threads, config.light_tree, config.fast_gi, config.max_bounces,
           config.denoise, n_slots, config.supersample)
    if STATE.get("key") != key:
        from .body import BodyModel

        if "body" not in STATE:
            STATE["body"] = BodyModel()
        if config.renderer == "pyrender":
            from .raster import RasterRenderer, pyrender_version

            # pyrender's framebuffer is already 4x multisampled
            STATE["renderer"] = RasterRenderer(n_slots=n_slots,
                                               supersample=config.supersample)
            STATE["renderer_version"] = pyrender_version()
        else:
            from .blender import BlenderRenderer, blender_version

            STATE["renderer"] = BlenderRenderer(
                threads=threads, n_slots=n_slots, light_tree=config.light_tree,
                fast_gi=config.fast_gi, max_bounces=config.max_bounces,
                denoise=config.denoise)
            STATE["renderer_version"] = blender_version()
        STATE["key"] = key
        STATE["layouts"] = {}
    return STATE["body"], STATE["renderer"]


def scene_layout(spec):
    """The layout of a scene spec, cached per process."""
    cache = STATE.setdefault("layouts", {})
    if spec.id not in cache:
        cache[spec.id] = layout_scene(spec)
    return cache[spec.id]


def _base_row(config: GeneratorConfig, kind, path, scene_id, lighting, cam: Camera, width,
              height, seed, render_seed, samples) -> dict:
    row = {c: None for c in ("person_id", "pose", "box_silhouette", "H_window_to_image",
                             "H_plane_to_image")}
    row["depth_path"] = ""
    row.update(path=path, kind=kind, scene_id=scene_id, K=json_matrix(cam.K),
               R=json_matrix(cam.R), t=json_matrix(cam.t), width=int(width),
               height=int(height), seed=int(seed), render_seed=int(render_seed),
               renderer=config.renderer,
               samples=int(samples) if config.renderer == "cycles"
               else 4 * config.supersample ** 2,
               supersample=int(config.supersample), framing=config.framing,
               distance=config.distance, person_height=config.person_height,
               person_id="", pose="", box_silhouette="", n_persons=0, stature=math.nan,
               gait_phase=math.nan, rotation=math.nan)
    row.update(lighting.to_columns())
    return row


def _remove_stale_temporaries(out: Path, unit: WorkUnit) -> None:
    """Delete temp files a killed run left for this unit's images and part file (a unit is
    only ever run by one worker at a time, so these cannot be in flight)."""
    for rel in unit_paths(unit) + unit_depth_paths(unit):
        p = out / rel
        if p.parent.is_dir():
            # and the raw render of an image with camera effects, and that file's temporaries
            for pattern in (f".{p.stem}.*", f".{raw_render_path(p).name}.*"):
                for tmp in p.parent.glob(pattern):
                    tmp.unlink(missing_ok=True)
    pp = part_path(out, unit.uid)
    if pp.parent.is_dir():
        for tmp in pp.parent.glob(f".{pp.name}.*"):
            tmp.unlink(missing_ok=True)


def _render_seed(seed: int, k: int) -> int:
    return int((seed + 7919 * k) % (2 ** 31 - 1))


def run_unit(payload: dict) -> dict:
    """Render one work unit (all its images), write its part file, return a summary.

    ``payload``: ``unit`` (WorkUnit), ``scene`` (SceneSpec), ``persons`` (id -> PersonSpec),
    ``config`` (GeneratorConfig), ``out`` (str), ``threads`` (int).
    """
    t0 = time.perf_counter()
    unit: WorkUnit = payload["unit"]
    spec = payload["scene"]
    persons = payload["persons"]
    config: GeneratorConfig = payload["config"]
    out = Path(payload["out"])
    threads = int(payload.get("threads") or STATE.get("threads") or 0)
    _remove_stale_temporaries(out, unit)
    body, renderer = worker_state(config, threads)
    layout = scene_layout(spec)
    renderer.load_scene(layout)
    from .annotate import (
        fit_silhouette_intrinsics, frame_annotations, person_to_world, silhouette_box,
    )

    rows, coco = [], None
    n_rendered = n_kept = n_repaired = 0
    plane_inv = np.linalg.inv(window_to_plane(config.person_height))
    effects_on = config.camera_effects != NO_EFFECTS

    def render_to(rel, cam, width, height, samples, seed, sample_seed):
        """Render the image ``rel`` unless a sound one is kept; with camera effects on,
        return its effects parameters (drawn whether or not it is rendered)."""
        nonlocal n_rendered, n_kept, n_repaired
        path = out / rel
        params = (draw_image_effects(config.camera_effects,
                                     derive_seed(sample_seed, "camera_effects", rel))
                  if effects_on else None)
        problem = check_image(path, (width, height))     # a full check; a bad file goes
        if problem is None:
            n_kept += 1
            return params
        renderer.set_camera(cam.K, cam.R, cam.t, width, height, config.supersample)
        if params is None:
            renderer.render(path, samples=samples, seed=seed)
        else:
            render_with_effects(renderer, path, params, samples=samples, seed=seed)
        n_rendered += 1
        n_repaired += problem != "missing"
        return params

    def record_effects(row, params):
        if effects_on:                   # off: the rows of a generator without effects
            row["camera_effects"] = effects_json(params)

    if unit.kind == "person":
        person = persons[unit.samples[0].person_id]
        w, h = config.crop_size
        for s in unit.samples:
            mesh = body.build(person, s.pose, s.gait_phase, s.pose_jitter)
            pts = person_to_world(mesh.all_points(), s.ground_xy, s.rotation)
            verts, faces = mesh.indexed()
            verts = person_to_world(verts, s.ground_xy, s.rotation)
            renderer.set_persons([(mesh, person, s.ground_xy, s.rotation)])
            renderer.set_lighting(s.lighting)
            for e, (cam, H) in enumerate(zip(s.cameras, s.homographies)):
                if config.framing == "silhouette":
                    K = fit_silhouette_intrinsics(cam, pts, w, h)
                    A = K @ np.linalg.inv(cam.K)
                    cam = Camera(K, cam.R, cam.t, (w, h))
                    H = A @ H
                rel = image_relpath("person", spec.id, person_id=person.id,
                                    instance=s.instance, elevation_index=e)
                rs = _render_seed(s.seed, e)
                fx = render_to(rel, cam, w, h, config.samples, rs, s.seed)
                drel = depth_relpath(rel)
                if check_depth(out / drel, (h, w)) is not None:
                    write_depth(out / drel, surface_depth(verts, faces, cam, (h, w)))
                row = _base_row(config, "person", rel, spec.id, s.lighting, cam, w, h,
                                s.seed, rs, config.samples)
                row["depth_path"] = drel
                record_effects(row, fx)
                box = silhouette_box(pts, cam, w, h)
                row.update(person_id=person.id, instance=s.instance,
                           elevation=float(config.elevations[e]), elevation_index=e,
                           azimuth=s.azimuth, rotation=s.rotation, ground_x=s.ground_xy[0],
                           ground_y=s.ground_xy[1], pose=s.pose, gait_phase=s.gait_phase,
                           stature=person.stature, n_persons=1,
                           H_window_to_image=json_matrix(H / H[2, 2]),
                           H_plane_to_image=json_matrix((H @ plane_inv) / H[2, 2]),
                           box_silhouette=json.dumps(box) if box else "")
                rows.append(row)
    elif unit.kind == "background":
        renderer.set_persons([])
        w, h = config.background_size
        for s in unit.samples:
            renderer.set_lighting(s.lighting)
            for e, (cam, H) in enumerate(zip(s.cameras, s.homographies)):
                rel = image_relpath("background", spec.id, index=s.index, elevation_index=e)
                rs = _render_seed(s.seed, e)
                fx = render_to(rel, cam, w, h, config.background_samples, rs, s.seed)
                row = _base_row(config, "background", rel, spec.id, s.lighting, cam, w, h,
                                s.seed, rs, config.background_samples)
                record_effects(row, fx)
                row.update(instance=s.index, elevation=float(config.elevations[e]),
                           elevation_index=e, azimuth=s.azimuth, ground_x=s.ground_xy[0],
                           ground_y=s.ground_xy[1],
                           H_window_to_image=json_matrix(H / H[2, 2]),
                           H_plane_to_image=json_matrix((H @ plane_inv) / H[2, 2]))
                rows.append(row)
    elif unit.kind == "frame":
        w, h = config.frame_size
        coco = {"images": [], "annotations": []}
        for s in unit.samples:
            placed, annot_in = [], []
            for fp in s.persons:
                person = persons[fp.person_id]
                mesh = body.build(person, fp.pose, fp.gait_phase, fp.pose_jitter)
                placed.append((mesh, person, fp.ground_xy, fp.rotation))
                annot_in.append((person_to_world(mesh.triangles(), fp.ground_xy, fp.rotation),
                                 person_to_world(mesh.all_points(), fp.ground_xy,
                                                 fp.rotation), fp.ground_xy))
            renderer.set_persons(placed)
            renderer.set_lighting(s.lighting)
            rel = image_relpath("frame", spec.id, index=s.index)
            rs = _render_seed(s.seed, 0)
            fx = render_to(rel, s.camera, w, h, config.frame_samples, rs, s.seed)
            anns = frame_annotations(s.camera, w, h, annot_in, layout)
            row = _base_row(config, "frame", rel, spec.id, s.lighting, s.camera, w, h, s.seed,
                            rs, config.frame_samples)
            fc = spec.frame_camera
            # frames: the camera is K/R/t (and frames_coco.json); per-person placement is in
            # the COCO annotations, so the per-crop placement columns are NaN here
            row.update(instance=s.index, elevation=math.nan, elevation_index=-1,
                       azimuth=math.nan, ground_x=math.nan, ground_y=math.nan,
                       n_persons=len(s.persons))
            record_effects(row, fx)
            rows.append(row)
            coco["images"].append({
                "file_name": rel, "width": w, "height": h, "scene_id": spec.id,
                "frame_index": s.index, "seed": s.seed, "K": s.camera.K.tolist(),
                "R": s.camera.R.tolist(), "t": s.camera.t.tolist(),
                "camera_height": fc.height, "camera_tilt": math.radians(fc.tilt_deg),
                "lighting": s.lighting.to_columns()})
            if fx is not None:
                coco["images"][-1]["camera_effects"] = fx
            for fp, a in zip(s.persons, anns):
                Hw = window_to_image_homography(s.camera, fp.ground_xy, config.person_height)
                coco["annotations"].append({
                    "file_name": rel, "category_id": 1, "iscrowd": 0,
                    "person_id": fp.person_id, "bbox": a["bbox"],
                    "bbox_visible": a["bbox_visible"], "occlusion": a["occlusion"],
                    "truncation": a["truncation"], "area": a["area"],
                    "area_visible": a["area_visible"],
                    "ground_position": [fp.ground_xy[0], fp.ground_xy[1], 0.0],
                    "rotation": fp.rotation, "pose": fp.pose,
                    "stature": persons[fp.person_id].stature,
                    "H_window_to_image": (Hw / Hw[2, 2]).tolist()})
    else:  # pragma: no cover
        raise ValueError(f"unknown unit kind {unit.kind!r}")
    write_part(out, unit.uid, rows, coco)
    return {"uid": unit.uid, "n_images": unit.n_images, "rendered": n_rendered,
            "kept": n_kept, "repaired": n_repaired, "seconds": time.perf_counter() - t0,
            "pid": os.getpid()}


# --------------------------------------------------------------------------- driver


def cpu_count() -> int:
    """CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover
        return os.cpu_count() or 1


def generate(config: GeneratorConfig, seed: int, out, *, jobs: int = 1, shard=None,
             scheduler: str | None = None, progress: bool = True, scene_dir=None,
             roster=None, threads: int | None = None, log=None,
             overwrite: bool = False) -> GenerateResult:
    """Generate (or finish, or extend by more frames or background views) a dataset in
    ``out``.

    Parameters
    ----------
    config : GeneratorConfig
    seed : int
        Master seed.
    out : path
        Dataset directory (created; an existing dataset must hold the same config and seed,
        up to a larger ``frames``; a non-empty directory that is no output of the project is
        refused unless ``overwrite``).
    jobs : int
        Worker processes (``-1``: one per core; ``0``: render in this process).
    shard : (int, int), optional
        Render only block ``i`` of ``n``.
    scheduler : str, optional
        Dask scheduler address; ``jobs`` is then ignored.

    Every kept file of a finished unit is checked (a full PNG check, depth maps read back)
    and a bad one rendered again. The manifest is assembled when the run ends cleanly; a
    complete dataset's ``dataset.json`` records its content hash
    (:func:`generator.manifest.content_hash`). An interrupted or failing run keeps what it
    rendered (a rerun resumes) and says so; it removes ``out`` if it made it and kept
    nothing. While it runs it holds ``out``'s lock (:mod:`viewadapt.io.locks`): a second
    run into ``out`` is refused naming this one; the shards of one plan share the folder.
    """
    t0 = time.perf_counter()
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a directory")
    if config.renderer == "pyrender":
        try:
            import pyrender  # noqa: F401
        except ImportError:
            raise ValueError("--renderer pyrender needs pyrender (pip install pyrender) and "
                             "an EGL or OSMesa OpenGL library; use --renderer cycles") from None
    scene_dir = Path(scene_dir) if scene_dir is not None else default_scene_dir()
    roster = Path(roster) if roster is not None else default_roster_path()
    plan = plan_dataset(config, seed, scenes=load_scenes(scene_dir),
                        persons=load_roster(roster))
    meta = dataset_metadata(config, seed, plan, scene_dir, roster)
    check_output_dir(out, overwrite=overwrite, command="generate")
    created = not out.exists()
    with hold_output_dir(out, "generate", shard=shard):
        return _generate_held(config, out, plan, meta, jobs=jobs, shard=shard,
                              scheduler=scheduler, progress=progress, threads=threads,
                              log=log, created=created, t0=t0)


def _generate_held(config, out: Path, plan, meta: dict, *, jobs, shard, scheduler, progress,
                   threads, log, created: bool, t0: float) -> GenerateResult:
    """The rest of :func:`generate`, while it holds ``out``'s lock."""
    meta_p = out / "dataset.json"
    if meta_p.is_file():
        # bounded: too large, too deeply nested or not UTF-8 is a one-line error naming it
        text = read_limited_text(meta_p, "dataset.json", MAX_INPUT_BYTES)
        check_json_depth(text, meta_p)
        try:
            old = json.loads(text)
        except json.JSONDecodeError:
            old = None
        if isinstance(old, dict) and str(old.get("format", "")).startswith("viewadapt"):
            check_resumable(old, meta, out)
    client = _dask_client(scheduler) if scheduler else None    # reachable, before writing
    try:
        out.mkdir(parents=True, exist_ok=True)
        write_marker(out, "generate")
        atomic_write_text(meta_p, json.dumps(meta, indent=2))
        units = select_shard(plan.units, shard)
        pending, repaired = pending_units(out, units, config)
    except BaseException as exc:
        if client is not None:
            client.close()
        raise interrupted(exc, out, plan, created) from None
    n_done_images = sum(u.n_images for u in units) - sum(u.n_images for u in pending)
    payloads = [{"unit": u, "scene": plan.scenes[u.scene_id],
                 "persons": {pid: plan.persons[pid] for pid in unit_person_ids(u)},
                 "config": config, "out": str(out)} for u in pending]

    from tqdm.auto import tqdm

    bar = tqdm(total=sum(u.n_images for u in units), initial=n_done_images, unit="img",
               desc=f"generate {config.preset}", disable=not progress, dynamic_ncols=True,
               smoothing=0.05)
    rendered = kept = 0
    runs = _execute(payloads, jobs=jobs, client=client, threads=threads)
    try:
        for res in runs:
            rendered += res["rendered"]
            kept += res["kept"]
            repaired += res.get("repaired", 0)
            bar.update(res["n_images"])
            if log is not None:
                log(res)
    except BaseException as exc:
        bar.close()
        runs.close()                 # the workers are stopped before what is kept is counted
        raise interrupted(exc, out, plan, created) from None
    finally:
        bar.close()
        if client is not None:
            client.close()
    df, missing = assemble_manifest(out, [u.uid for u in plan.units])
    if not missing:
        atomic_write_text(meta_p, json.dumps(dict(meta, content_hash=content_hash(out, df)),
                                             indent=2))
    return GenerateResult(out, len(plan.units), len(pending), plan.n_images, rendered,
                          kept + n_done_images, time.perf_counter() - t0, not missing,
                          repaired)


def unit_person_ids(u: WorkUnit) -> list[str]:
    """The persons a work unit renders (ids into the plan's persons)."""
    if u.kind == "person":
        return [u.samples[0].person_id]
    if u.kind == "frame":
        return sorted({p.person_id for s in u.samples for p in s.persons})
    return []


def _execute(payloads, *, jobs, client=None, threads=None):
    if not payloads:
        return
    if client is not None:
        yield from _execute_dask(payloads, client, threads)
        return
    ncpu = cpu_count()
    if jobs is None or jobs < 0:
        jobs = ncpu
    if jobs == 0:
        STATE.setdefault("threads", threads or ncpu)
        for p in payloads:
            yield run_unit(dict(p, threads=threads or ncpu))
        return
    per = threads or max(1, ncpu // jobs)
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    ctx = mp.get_context("spawn")
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_worker_init,
                             initargs=(per,)) as ex:
        futs = [ex.submit(run_unit, dict(p, threads=per)) for p in payloads]
        try:
            for f in as_completed(futs):
                yield f.result()
        except BaseException:
            for f in futs:
                f.cancel()
            raise


#: how long ``--scheduler`` waits for the Dask scheduler before giving up
SCHEDULER_TIMEOUT_S = 10


def _dask_client(scheduler: str):
    """A client of the Dask scheduler at ``scheduler``; a one-line error if unreachable."""
    try:
        from distributed import Client
    except ImportError as exc:
        raise ValueError("--scheduler needs dask: pip install 'dask[distributed]'") from exc
    try:
        return Client(scheduler, set_as_default=False, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there within "
                        f"{SCHEDULER_TIMEOUT_S} s ({exc.__class__.__name__}); nothing was "
                        "written") from None


def _execute_dask(payloads, client, threads):
    from distributed import as_completed

    futs = client.map(run_unit, [dict(p, threads=threads or 0) for p in payloads],
                      pure=False, key=[f"unit-{p['unit'].uid}" for p in payloads])
    try:
        for f in as_completed(futs, loop=client.loop):
            yield f.result()
    except BaseException:
        client.cancel(futs)
        raise
