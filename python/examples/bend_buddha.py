"""Bends the Happy Buddha: its raised hands, and what they hold, tilted 30 degrees and moved
sideways, refined as-rigidly-as-possible.

    PYTHONPATH=build/python /usr/bin/python3 python/examples/bend_buddha.py ../shared/meshes/buddha out/
"""
import sys
from pathlib import Path

import numpy as np
import hdeform

folder, out = Path(sys.argv[1]), Path(sys.argv[2])
V, F = hdeform.read_mesh(folder / "buddha-206k.obj")
fixed = np.loadtxt(folder / "buddha-206k-fixed.txt", dtype=np.int64)
hands = np.loadtxt(folder / "buddha-206k-handle.txt", dtype=np.int64)
turn = hdeform.Transform(np.loadtxt(folder / "buddha-206k-transform.txt"))

deformer = hdeform.Deformer(V, F, fixed, [hands], refine="auto")
bent = deformer.deform([turn])
out.mkdir(parents=True, exist_ok=True)
hdeform.write_mesh(out / "buddha-bent.ply", bent, F)
print(f"moved {np.count_nonzero(np.any(bent != V, axis=1))} of {len(V)} vertices, "
      f"{deformer.refinement['iterations']} refinement iterations")
if hdeform.has_render:
    hdeform.render(bent, F, out / "buddha-bent.png", fixed=fixed, handles=[hands])
