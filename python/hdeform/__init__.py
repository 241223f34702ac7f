"""hdeform: detail-preserving surface deformation guided by harmonic fields (Zayer et al. 2005).

Arguments: positions V are (n, 3) arrays of any float dtype (float32 is widened to float64) or
nested lists of floats; triangles F are (m, 3) arrays of any integer dtype (0-based indices) or
nested lists; vertex lists are 1-D integer arrays or lists. A wrong shape or dtype raises
ValueError naming the argument. Results are float64 (positions, fields) or int32 (indices) numpy
arrays that own the solver's memory (no copy). The GIL is released while anything is solved. Bad
data raises hdeform.InputError (a ValueError) with the command line's message, a failed
factorization hdeform.SolveError.

    import hdeform
    V, F = hdeform.read_mesh("buddha.obj")
    deformer = hdeform.Deformer(V, F, fixed, [handle], refine="auto")
    bent = deformer.deform([hdeform.Transform(matrix_3x4)])

help(hdeform.Deformer) describes every argument.
"""
from ._core import (  # noqa: F401
    Deformer,
    InputError,
    SolveError,
    Transform,
    add_relief,
    correspondence,
    harmonic_field,
    has_render,
    read_mesh,
    render,
    shape,
    subdivide,
    transfer,
    triangulate,
    write_mesh,
)
from ._core import _cotangent_laplacian_csc

__all__ = [
    "Deformer", "InputError", "SolveError", "Transform", "add_relief", "correspondence", "cotangent_laplacian",
    "harmonic_field", "has_render", "read_mesh", "render", "shape", "subdivide", "transfer", "triangulate", "write_mesh",
]


def cotangent_laplacian(V, F):
    """The cotangent Laplacian L of V ((n, 3) floats) and F ((m, 3) integers): n x n, symmetric
    positive semi-definite, zero row sums, L_ij = -(cot a + cot b)/2 on an edge.

    A scipy.sparse.csc_matrix of float64 when scipy is installed, else the CSC arrays
    (data float64, indices int32, indptr int32, shape)."""
    data, indices, indptr, n = _cotangent_laplacian_csc(V, F)
    try:
        import scipy.sparse
    except ImportError:
        return data, indices, indptr, (n, n)
    return scipy.sparse.csc_matrix((data, indices, indptr), shape=(n, n))
