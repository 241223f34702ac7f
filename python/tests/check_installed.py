"""Run by install_and_import.cmake with PYTHONPATH set to an installed prefix's site-packages."""
import sys

import numpy as np

import hdeform

prefix = sys.argv[1]
assert hdeform.__file__.startswith(prefix), f"imported {hdeform.__file__}, not from {prefix}"
cactus = hdeform.shape("cactus", 16)
bent = hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]).deform([cactus["transform"]])
assert np.array_equal(bent[cactus["fixed"]], cactus["V"][cactus["fixed"]])
print("imported from", hdeform.__file__)
