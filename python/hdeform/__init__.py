"""hdeform: detail-preserving surface deformation guided by harmonic fields (Zayer et al. 2005).

Positions are (n, 3) float64 arrays, triangles (m, 3) integer arrays, vertex lists 1-D integer
arrays; results come back as numpy arrays without a copy. The GIL is released while solving.
Bad input raises hdeform.InputError (a ValueError) with the command line's message.

    import hdeform
    V, F = hdeform.read_mesh("buddha.obj")
    deformer = hdeform.Deformer(V, F, fixed, [handle], refine="auto")
    bent = deformer.deform([hdeform.Transform(matrix_3x4)])
"""
from ._core import (  # noqa: F401
    Deformer,
    InputError,
    SolveError,
    Transform,
    correspondence,
    harmonic_field,
    has_render,
    read_mesh,
    render,
    shape,
    transfer,
    triangulate,
    write_mesh,
)
from ._core import _cotangent_laplacian_csc

__all__ = [
    "Deformer", "InputError", "SolveError", "Transform", "correspondence", "cotangent_laplacian", "harmonic_field",
    "has_render", "read_mesh", "render", "shape", "transfer", "triangulate", "write_mesh",
]


def cotangent_laplacian(V, F):
    """The cotangent Laplacian L (n x n, symmetric positive semi-definite, zero row sums; design.md).

    A scipy.sparse.csc_matrix when scipy is installed, else the CSC arrays
    (data, indices, indptr, shape)."""
    data, indices, indptr, n = _cotangent_laplacian_csc(V, F)
    try:
        import scipy.sparse
    except ImportError:
        return data, indices, indptr, (n, n)
    return scipy.sparse.csc_matrix((data, indices, indptr), shape=(n, n))
