"""Setting a solver up off Blender's main thread: the factorization of a large mesh takes a second
or more, and the interface must not freeze meanwhile. The vertex groups and the mesh are read on
the main thread (Setup), the Deformer is built on a worker (the module releases the GIL), and what
follows is done back on the main thread, from a timer, when the worker is done."""
import threading

import bpy

from . import solver


class Job:
    def __init__(self, obj, setup, finish):
        self.key = solver.key(obj)
        self.setup = setup
        self.finish = finish  # finish(obj, setup, deformer or None, error or None), on the main thread; or None
        self.stage = "reading the mesh"
        self.deformer = None
        self.error = None
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        try:
            self.deformer = solver.build(self.setup, progress=self._progress)
        except solver.SetupError as error:
            self.error = str(error)
        except Exception as error:  # noqa: BLE001 - anything else is reported, never lost on a thread
            self.error = type(error).__name__ + ": " + str(error)
        self.done.set()

    def _progress(self, stage):
        self.stage = stage


_jobs = {}  # solver.key(object): Job


def running(obj):
    job = _jobs.get(solver.key(obj))
    return job.stage if job is not None else None


def start(obj, setup, finish=None):
    """Builds the object's solver on a worker and returns the job (None when one runs already);
    `finish` runs on the main thread when it is done, else the caller takes the job (take())."""
    if solver.key(obj) in _jobs:
        return None
    job = Job(obj, setup, finish)
    _jobs[job.key] = job
    job.thread.start()
    if not bpy.app.timers.is_registered(_poll):
        bpy.app.timers.register(_poll, first_interval=0.05)
    return job


def take(job):
    """A finished job whose caller finishes it (the Bind operator, to report in Blender's way)."""
    _jobs.pop(job.key, None)


def _poll():
    for job_key, job in list(_jobs.items()):
        if not job.done.is_set() or job.finish is None:
            continue
        del _jobs[job_key]
        obj = bpy.data.objects.get(job_key[1])
        if obj is not None and solver.key(obj) == job_key:
            job.finish(obj, job.setup, job.deformer, job.error)
    solver.redraw_panels()  # the panel's progress line
    return 0.1 if _jobs else None


def forget_all():
    _jobs.clear()
