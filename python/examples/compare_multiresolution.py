"""The Happy Buddha at scan resolution (3.3 million triangles: subdivided twice, with relief so that
the detail is real), its hands bent as in bend_buddha.py, solved on every vertex and on a base
mesh that carries the detail (multiresolution). Writes both results and their difference as
pictures, and prints how far apart they are, how many triangles fold, and what each cost.

    PYTHONPATH=build/python /usr/bin/python3 python/examples/compare_multiresolution.py ../shared/meshes/buddha out/ [LEVELS]

LEVELS: how many times the Buddha is subdivided (default 2; 1 gives 822K triangles). At 2, about
3 GB of memory and a minute on two cores (the exact solve's factorization is most of it).
"""
import sys
import time
from pathlib import Path

import numpy as np
import hdeform

folder, out = Path(sys.argv[1]), Path(sys.argv[2])
levels = int(sys.argv[3]) if len(sys.argv) > 3 else 2
name = {0: "buddha-206k", 1: "buddha-822k", 2: "buddha-3m", 3: "buddha-13m"}.get(levels, f"buddha-{levels}x")
V, F = hdeform.read_mesh(folder / "buddha-206k.obj")
fixed = np.loadtxt(folder / "buddha-206k-fixed.txt", dtype=np.int64)
hands = np.loadtxt(folder / "buddha-206k-handle.txt", dtype=np.int64)
turn = hdeform.Transform(np.loadtxt(folder / "buddha-206k-transform.txt"))

V, F, (fixed, hands) = hdeform.subdivide(V, F, levels=levels, sets=[fixed, hands])
V = hdeform.add_relief(V, F, 0.001)
diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
print(f"{len(V):,} vertices, {len(F):,} triangles")

results = {}
for resolution in ("exact", "multiresolution"):
    began = time.perf_counter()
    deformer = hdeform.Deformer(V, F, fixed, [hands], resolution=resolution)
    ready = time.perf_counter() - began
    deformer.deform([hdeform.Transform(np.eye(4)[:3])])  # the first update also warms the caches
    results[resolution] = deformer.deform([turn])
    timings = deformer.timings
    print(f"{resolution}: solves on {deformer.solved_vertex_count:,} vertices; set-up {ready:.1f} s, "
          f"an update {timings['last_update_ms']:.1f} ms (the fine mesh rebuilt in {timings['last_detail_ms']:.1f} ms of it)")
    del deformer

deviation = np.linalg.norm(results["multiresolution"] - results["exact"], axis=1) / diagonal
print(f"multiresolution against exact, as a fraction of the diagonal: mean {deviation.mean():.2e}, "
      f"largest {deviation.max():.2e}")


def triangle_normals(positions):
    return np.cross(positions[F[:, 1]] - positions[F[:, 0]], positions[F[:, 2]] - positions[F[:, 0]])


# Where a base triangle lies over much smaller ones in a strongly curved place, a few of those fold.
folded = np.sum((triangle_normals(results["exact"]) * triangle_normals(results["multiresolution"])).sum(axis=1) < 0)
print(f"triangles facing the other way than in the exact solve: {folded:,} of {len(F):,}")
out.mkdir(parents=True, exist_ok=True)
if hdeform.has_render:
    view = dict(size="640x800", camera="-25,5,0.8")
    hdeform.render(results["exact"], F, out / f"{name}-exact.png", fixed=fixed, handles=[hands], **view)
    hdeform.render(results["multiresolution"], F, out / f"{name}-multiresolution.png", fixed=fixed, handles=[hands], **view)
    # The colour bar's 1 is the 99th percentile of the deviation (a few vertices, where the relief is
    # steepest, lie beyond it and take the top colour).
    top = np.percentile(deviation, 99)
    if top > 0:
        print(f"difference picture: 1 on its colour bar is {top:.2e} of the diagonal")
    else:  # a base that is the whole mesh (LEVELS 0): the two agree everywhere
        top = 1.0
        print("difference picture: the results agree everywhere, so it is all 0")
    hdeform.render(results["multiresolution"], F, out / f"{name}-difference.png", field=np.minimum(deviation / top, 1.0), **view)
