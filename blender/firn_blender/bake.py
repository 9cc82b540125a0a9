"""Baking: the scene file and meshes into the cache folder, the run through
the `firn` module, and the caches back into Blender.

In Blender's interface the run goes on a background thread (firn releases
the GIL while it steps) and a modal timer shows its progress; only the
main thread touches Blender's data. Under `blender -b` the same operator
runs synchronously. Cancelling stops the run after the frame in progress,
which leaves its checkpoint: baking the same scene again resumes it, to
the same bytes as a bake never stopped."""

import json
import os
import re
import shutil
import sys
import threading
import time

import bpy

from . import export, importer

SCENE_FILE = "scene.toml"
#: The one bake in progress in this Blender, if any.
_job = None


class CancelledError(Exception):
    """Raised from firn's progress callback to stop the run."""


class BakeError(Exception):
    """A scene firn refuses, with a message naming the Blender object."""


def firn_module():
    """The `firn` Python module: importable, or in the add-on's preference
    folder. Raises ImportError saying how to install it."""
    try:
        import firn

        return firn
    except ImportError:
        pass
    folder = preferences_module_folder()
    if folder and folder not in sys.path:
        sys.path.append(folder)
        try:
            import firn

            return firn
        except ImportError:
            pass
    raise ImportError(
        "the firn Python module is not installed for Blender's Python: run "
        "scripts/blender/install-addon.sh, or set its folder in the add-on's preferences"
    )


def preferences_module_folder():
    """The folder of the firn module set in the add-on's preferences."""
    addon = bpy.context.preferences.addons.get(__package__)
    if addon is None:
        return ""
    return bpy.path.abspath(addon.preferences.module_folder)


def cache_folder(scene):
    """The absolute cache folder of `scene`."""
    folder = scene.firn.cache_directory
    if folder.startswith("//") and not bpy.data.filepath:
        folder = os.path.join(bpy.app.tempdir, folder[2:])
    return os.path.abspath(bpy.path.abspath(folder))


def blender_message(error, origins):
    """firn's SceneError as a message naming the Blender object and setting."""
    key = getattr(error, "key", None) or ""
    detail = str(error).split("\n")[0]
    detail = re.sub(r"^error: ", "", detail)
    detail = re.sub(r" \(set from Python: .*\)$", "", detail)
    hint = getattr(error, "hint", "")
    for prefix, (name, what) in sorted(origins.items(), key=lambda item: -len(item[0])):
        if key == prefix or key.startswith(prefix + ".") or key.startswith(prefix + "["):
            setting = key[len(prefix) + 1 :] or what
            if what == "rigid body":
                setting = export.RIGID_BODY_SETTINGS.get(setting, setting)
            detail = re.sub(key_pattern(prefix) + r"\.(\w+)", rf"the {what}'s \1", detail)
            detail = re.sub(key_pattern(prefix) + r"( \(\w+\))?", f"the {what}", detail)
            detail, hint = named(detail, origins), named(hint, origins)
            text = f"{name} ({what}), {setting}: {detail}"
            if re.search(r"along [xyz]\b|\b[xyz] = ", detail):
                text += " (in firn's axes: x, y, z are Blender's x, z, -y)"
            return text + (f"; fix: {hint}" if hint else "")
    detail, hint = named(detail, origins), named(hint, origins)
    return f"firn: {detail}" + (f"; fix: {hint}" if hint else "")


def key_pattern(prefix):
    """A regular expression of firn's key `prefix` standing alone (not the
    end of a longer key: bodies[0] is not in rigid_bodies[0])."""
    return r"(?<![\w.])" + re.escape(prefix) + r"(?![\w\[])"


def named(text, origins):
    """`text` with firn's keys of listed parts (colliders[2]) replaced by
    the Blender objects they came from (Ground (collider))."""
    for prefix, (name, what) in sorted(origins.items(), key=lambda item: -len(item[0])):
        if "[" not in prefix:
            continue
        text = re.sub(key_pattern(prefix), lambda _, label=f"{name} ({what})": label, text)
    return text


def material_origins(made):
    """Adds `materials.NAME` of custom materials to the origins."""
    for index, body in enumerate(made.scene["bodies"]):
        name, _ = made.origins[f"bodies[{index}]"]
        if body["material"] in made.scene.get("materials", {}):
            made.origins[f"materials.{body['material']}"] = (name, "snow material")


class Job:
    """A bake: the scene to run, where, and what the run has reported."""

    def __init__(self, firn, scene, run_directory, resume, made, cancel_after):
        self.firn = firn
        self.scene = scene
        self.run_directory = run_directory
        self.resume = resume
        self.made = made
        self.cancel_after = cancel_after
        self.cancel = threading.Event()
        self.latest = {}
        self.error = None
        self.cancelled = False
        self.done = False
        self.baked_before = False
        self.echo = False
        self.started = time.monotonic()

    def progress(self, info):
        """firn's callback after each frame: keeps it, stops on cancel."""
        self.latest = dict(info)
        if self.echo:
            print(f"firn: {self.status()}", flush=True)
        if self.cancel.is_set() or 0 <= self.cancel_after <= info["frame"]:
            raise CancelledError()

    def run(self):
        """Runs the scene to its end (on any thread)."""
        try:
            self.firn.run(self.scene, out=self.run_directory, render=False, resume=self.resume, progress=self.progress)
        except CancelledError:
            self.cancelled = True
        except Exception as error:  # noqa: BLE001 -- shown to the user as a report
            self.error = error
        finally:
            self.done = True

    def status(self):
        """One line: frame, simulated time and the estimated time left."""
        info = self.latest
        if not info:
            return "Starting..." if not self.resume else "Resuming..."
        eta = info.get("eta_seconds")
        eta_text = f", ETA {eta:.0f} s" if eta is not None else ""
        return f"Frame {info['frame']}/{info['last_frame']}, {info['time']:.3f} s{eta_text}"

    def fraction(self):
        """How much of the run is done, 0 to 1."""
        info = self.latest
        if not info or not info.get("last_frame"):
            return 0.0
        return info["frame"] / info["last_frame"]


def run_state(run_directory, scene_path, toml):
    """The state ("running", "finished", "failed") of the run in
    `run_directory` when it was made from the same scene text, else None."""
    manifest = os.path.join(run_directory, "manifest.json")
    if not (os.path.exists(manifest) and os.path.exists(scene_path)):
        return None
    with open(scene_path, encoding="utf-8") as file:
        if file.read() != toml:
            return None
    with open(manifest, encoding="utf-8") as file:
        return json.load(file).get("status", {}).get("state")


def prepare(context, cancel_after):
    """The scene's firn scene written into the cache; a Job, or raises
    ExportError or a message (str) for the user."""
    firn = firn_module()
    scene = context.scene
    cache = cache_folder(scene)
    run_directory = os.path.join(cache, export.RUN_FOLDER)
    made = export.build(scene, context.evaluated_depsgraph_get, run_directory)
    material_origins(made)
    for name, data in made.meshes.items():
        path = os.path.join(cache, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as file:
            file.write(data)
    scene_path = os.path.join(cache, SCENE_FILE)
    try:
        firn_scene = firn.Scene.from_dict(made.scene, origin=scene_path)
    except firn.SceneError as error:
        raise BakeError(blender_message(error, made.origins)) from error
    toml = firn_scene.to_toml()
    state = run_state(run_directory, scene_path, toml)
    resume = state == "running" and os.path.exists(os.path.join(run_directory, "checkpoint.firnckpt"))
    job = Job(firn, firn_scene, run_directory, resume, made, cancel_after)
    if state == "finished":
        job.done = job.baked_before = True
        return job
    if not resume and os.path.exists(run_directory):
        shutil.rmtree(run_directory)
    with open(scene_path, "w", encoding="utf-8") as file:
        file.write(toml)
    return job


def finish(operator, context, job):
    """Reports the run's end and imports what it wrote."""
    global _job
    _job = None
    settings = context.scene.firn
    settings.baking = False
    made = job.made
    hide_snow(context.scene)
    importer.load_run(context.scene, job.run_directory, made.frame_start, made.frame_count + 1)
    if job.error is not None:
        settings.status = f"Failed: {job.error}"
        operator.report({"ERROR"}, f"firn: {job.error}")
        return {"CANCELLED"}
    if job.cancelled:
        settings.status = f"Cancelled after frame {job.latest.get('frame', 0)}: bake again to resume"
        operator.report({"WARNING"}, settings.status)
        return {"CANCELLED"}
    seconds = time.monotonic() - job.started
    if job.baked_before:
        settings.status = "Already baked: loaded the caches (Free Bake to bake again)"
        operator.report({"INFO"}, settings.status)
        return {"FINISHED"}
    settings.status = f"Baked {made.frame_count + 1} frames in {seconds:.1f} s" + (" (resumed)" if job.resume else "")
    settings.progress = 1.0
    operator.report({"INFO"}, settings.status)
    return {"FINISHED"}


def hide_snow(scene):
    """Shows the snow bodies as wires and leaves them out of renders: the
    baked snow takes their place."""
    for obj in export.role_objects(scene, "SNOW"):
        obj.hide_render = True
        obj.display_type = "WIRE"


def redraw(context):
    """Redraws the panels that show the bake's progress."""
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type in {"PROPERTIES", "VIEW_3D"}:
                area.tag_redraw()


class FIRN_OT_bake(bpy.types.Operator):
    """Bake the firn simulation of the scene into its cache folder, and
    load the result (resumes a cancelled bake of the same scene)"""

    bl_idname = "firn.bake"
    bl_label = "Bake Snow"
    bl_options = {"REGISTER"}

    cancel_after_frame: bpy.props.IntProperty(
        name="Cancel After Frame",
        default=-1,
        options={"HIDDEN", "SKIP_SAVE"},
        description="Stop as a cancel would after this frame (-1: run to the end); for tests and farms",
    )
    synchronous: bpy.props.BoolProperty(
        name="Synchronous",
        default=False,
        options={"HIDDEN", "SKIP_SAVE"},
        description="Run in the calling thread (always so under blender -b)",
    )

    @classmethod
    def poll(cls, context):
        return (
            _job is None and context.scene is not None and any(o.firn.role == "DOMAIN" for o in context.scene.objects)
        )

    def execute(self, context):
        global _job
        settings = context.scene.firn
        try:
            job = prepare(context, self.cancel_after_frame)
        except (export.ExportError, BakeError, ImportError) as error:
            settings.status = f"Error: {error}"
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        _job = job
        settings.baking = True
        settings.progress = 0.0
        if job.baked_before:
            return finish(self, context, job)
        if bpy.app.background or self.synchronous or context.window_manager.windows[:] == []:
            return self.run_here(context, job)
        threading.Thread(target=job.run, name="firn bake", daemon=True).start()
        self.timer = context.window_manager.event_timer_add(0.2, window=context.window)
        context.window_manager.modal_handler_add(self)
        context.window_manager.progress_begin(0.0, 1.0)
        return {"RUNNING_MODAL"}

    def run_here(self, context, job):
        """Runs the bake in this thread, printing progress lines."""
        job.echo = True
        job.run()
        return finish(self, context, job)

    def modal(self, context, event):
        job = _job
        if event.type == "ESC" and job is not None:
            job.cancel.set()
        if event.type != "TIMER" or job is None:
            return {"PASS_THROUGH"}
        settings = context.scene.firn
        settings.status = job.status()
        settings.progress = job.fraction()
        context.window_manager.progress_update(job.fraction())
        redraw(context)
        if not job.done:
            return {"PASS_THROUGH"}
        context.window_manager.event_timer_remove(self.timer)
        context.window_manager.progress_end()
        return finish(self, context, job)


class FIRN_OT_cancel_bake(bpy.types.Operator):
    """Stop the bake after the frame in progress; bake again to resume it"""

    bl_idname = "firn.cancel_bake"
    bl_label = "Cancel Bake"

    @classmethod
    def poll(cls, context):
        return _job is not None

    def execute(self, context):
        _job.cancel.set()
        return {"FINISHED"}


class FIRN_OT_load_bake(bpy.types.Operator):
    """Load the frames baked in the cache folder (surface, volume, particles)"""

    bl_idname = "firn.load_bake"
    bl_label = "Load Bake"

    @classmethod
    def poll(cls, context):
        return _job is None and context.scene is not None

    def execute(self, context):
        scene = context.scene
        run_directory = os.path.join(cache_folder(scene), export.RUN_FOLDER)
        frames = scene.frame_end - scene.frame_start + 1
        made = importer.load_run(scene, run_directory, scene.frame_start, frames)
        if not made:
            self.report({"ERROR"}, f"no baked frames in {run_directory}")
            return {"CANCELLED"}
        return {"FINISHED"}


class FIRN_OT_free_bake(bpy.types.Operator):
    """Delete the baked caches of the scene (the scene file and meshes stay)"""

    bl_idname = "firn.free_bake"
    bl_label = "Free Bake"

    @classmethod
    def poll(cls, context):
        return _job is None and context.scene is not None

    def execute(self, context):
        run_directory = os.path.join(cache_folder(context.scene), export.RUN_FOLDER)
        if os.path.exists(run_directory):
            shutil.rmtree(run_directory)
        context.scene.firn.status = "Freed"
        return {"FINISHED"}


CLASSES = (FIRN_OT_bake, FIRN_OT_cancel_bake, FIRN_OT_load_bake, FIRN_OT_free_bake)


def register():
    """Registers the operators."""
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    """Unregisters the operators."""
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
