"""The Python module against the command line (bit for bit), against what the math guarantees, and
at its edges: bad shapes and dtypes, the command line's error messages, the GIL released."""
import os
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import hdeform

EXECUTABLE = os.environ.get("HDEFORM_EXECUTABLE", "hdeform")
SOURCE_DIR = Path(os.environ.get("HDEFORM_SOURCE_DIR", Path(__file__).resolve().parents[2]))
SHARED = Path(os.environ.get("HDEFORM_SHARED_MESHES", SOURCE_DIR.parent / "shared" / "meshes"))
needs_shared = pytest.mark.skipif(not SHARED.is_dir(), reason=f"{SHARED} is absent (set HDEFORM_SHARED_MESHES)")


def run_cli(*arguments):
    return subprocess.run([EXECUTABLE, *map(str, arguments)], capture_output=True, text=True)


def cli_edit(tmp_path, *arguments):
    out = tmp_path / "cli.obj"
    result = run_cli("edit", *arguments, "--out", out, "--quiet")
    assert result.returncode == 0, result.stderr
    return hdeform.read_mesh(out)[0]


@pytest.mark.parametrize("refine", [0, "auto"])
def test_the_cactus_demo_equals_the_command_line_bit_for_bit(tmp_path, refine):
    expected = cli_edit(tmp_path, "--shape", "cactus", "--refine", refine)
    cactus = hdeform.shape("cactus")
    deformer = hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"], refine=refine)
    assert np.array_equal(deformer.deform([cactus["transform"]]), expected)


def test_a_refined_pose_is_the_same_whatever_poses_came_before():
    # A drag that reverses past the rest shape, deformed one pose after another by one Deformer,
    # against a fresh Deformer at each pose: the same positions and energies, bit for bit.
    cylinder = hdeform.shape("cylinder", 12)
    arguments = (cylinder["V"], cylinder["F"], cylinder["fixed"], cylinder["handles"])
    driven = hdeform.Deformer(*arguments, refine="auto")
    for x in (0.3, 0.6, 0.3, 0.0, -0.3):
        pose = np.hstack([np.eye(3), [[x], [0.0], [0.0]]])
        shown = driven.deform(pose)
        fresh = hdeform.Deformer(*arguments, refine="auto")
        assert np.array_equal(shown, fresh.deform(pose)), x
        assert driven.refinement == fresh.refinement, x
        if x != 0.0:
            assert driven.refinement["iterations"] > 3 and driven.refinement["converged"], (x, driven.refinement)


def test_refining_a_few_iterations_at_a_time_gives_the_same_bits_as_at_once():
    # What a caller that shows a drag live does: the paper's update now, iterations between events.
    cylinder = hdeform.shape("cylinder", 12)
    stages = []
    deformer = hdeform.Deformer(cylinder["V"], cylinder["F"], cylinder["fixed"], cylinder["handles"], progress=stages.append)
    assert any("factoring" in stage for stage in stages) and all(isinstance(stage, str) for stage in stages), stages
    pose = np.hstack([np.eye(3), [[0.4], [0.0], [-0.1]]])
    at_once = deformer.deform(pose, refine="auto")
    status = dict(deformer.refinement)
    paper = deformer.deform(pose, refine=0)
    assert deformer.refinement["iterations"] == 0
    steps = 0
    while not deformer.refinement["converged"]:
        shown = deformer.refine(2)
        steps += 1
        assert steps < 500
    assert np.array_equal(shown, at_once) and deformer.refinement == status
    assert not np.array_equal(paper, at_once)
    with pytest.raises(ValueError, match="refine_tolerance"):
        deformer.refine_tolerance = 2.0
    deformer.refine_tolerance = 1e-3
    loose = deformer.deform(pose, refine="auto")
    assert deformer.refinement["iterations"] < status["iterations"] and not np.array_equal(loose, at_once)
    with pytest.raises(ValueError, match="progress"):
        hdeform.Deformer(cylinder["V"], cylinder["F"], cylinder["fixed"], cylinder["handles"], progress="not callable")
    with pytest.raises(ValueError, match="deform"):
        hdeform.Deformer(cylinder["V"], cylinder["F"], cylinder["fixed"], cylinder["handles"]).refine()


def test_a_twist_with_a_shift_moves_its_pivot():
    twist = hdeform.Transform.twist(axis=(0, 0, 1), point=(1, 0, 0), degrees=90, scale=2.0, shift=(0, 0, 3))
    # p -> point + shift + scale R (p - point): (2, 0, 0) goes to (1, 0, 3) + 2 (0, 1, 0).
    assert np.allclose(twist.matrix @ [2, 0, 0, 1], [1, 2, 3], atol=1e-12)
    assert twist.degrees == 90.0 and twist.scale == 2.0


def test_polygons_are_triangulated_as_the_obj_reader_does(tmp_path):
    V = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [1, 2, 0], [-1, 1.5, 0], [-1, 0.5, 0]], dtype=float)
    faces = [[0, 1, 2, 3], [3, 2, 4], [0, 3, 5, 6]]
    (tmp_path / "poly.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in V) + "".join("f " + " ".join(str(v + 1) for v in f) + "\n" for f in faces))
    _, F = hdeform.read_mesh(tmp_path / "poly.obj")
    ours = hdeform.triangulate(V, [len(f) for f in faces], [v for f in faces for v in f])
    assert np.array_equal(ours, F)
    # The quad 0-1-2-3 is 2 by 1: split along a diagonal of length sqrt(5) either way (a tie: 1-3).
    assert ours.shape == (5, 3)
    with pytest.raises(ValueError, match="polygon 0"):
        hdeform.triangulate(V, [2], [0, 1])
    with pytest.raises(ValueError, match="out of range"):
        hdeform.triangulate(V, [3], [0, 1, 9])


def test_the_settle_stop_is_the_editors_and_the_command_lines(tmp_path):
    expected = cli_edit(tmp_path, "--shape", "cactus", "--refine", "auto", "--refine-settle", "1e-4")
    cactus = hdeform.shape("cactus")
    deformer = hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"], refine="auto", refine_settle=1e-4)
    assert np.array_equal(deformer.deform([cactus["transform"]]), expected)
    assert deformer.refinement["settled"] and deformer.refinement["largest_step"] <= 1e-4
    with pytest.raises(ValueError, match="refine_settle"):
        hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"], refine="auto", refine_settle=-1.0)


def test_multiresolution_equals_the_command_lines_and_keeps_the_constraints_exact(tmp_path):
    cactus = hdeform.shape("cactus", 32)
    V, F, fixed, handles = cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]
    base = len(V) // 4
    expected = cli_edit(tmp_path, "--shape", "cactus", "--resolution", 32, "--multiresolution", "--base-vertices", base, "--refine", 5)
    deformer = hdeform.Deformer(V, F, fixed, handles, resolution="multiresolution", base_vertices=base, refine=5)
    assert deformer.resolution == "multiresolution"
    assert deformer.solved_vertex_count < len(V)
    shown = deformer.deform([cactus["transform"]])
    assert np.array_equal(shown, expected)
    assert np.array_equal(shown[fixed], V[fixed])
    assert np.array_equal(deformer.deform(np.eye(4)), V), "nothing moved: the mesh to the last bit"
    small = hdeform.Deformer(V, F, fixed, handles)
    assert small.resolution == "exact" and small.solved_vertex_count == len(V), "a small mesh solves exactly by default"
    with pytest.raises(ValueError, match="resolution"):
        hdeform.Deformer(V, F, fixed, handles, resolution="coarse")


def test_single_precision_factors_equal_the_command_lines_and_the_double_solve(tmp_path):
    cactus = hdeform.shape("cactus", 32)
    V, F, fixed, handles = cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]
    expected = cli_edit(tmp_path, "--shape", "cactus", "--resolution", 32, "--precision", "single", "--refine", 3)
    deformer = hdeform.Deformer(V, F, fixed, handles, refine=3, precision="single")
    assert deformer.precision == "single"
    shown = deformer.deform([cactus["transform"]])
    assert np.array_equal(shown, expected), "the same bits as the command line"
    in_double = hdeform.Deformer(V, F, fixed, handles, refine=3).deform([cactus["transform"]])
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    assert np.abs(shown - in_double).max() <= 1e-10 * diagonal
    assert np.array_equal(shown[fixed], V[fixed])
    field = hdeform.harmonic_field(V, F, handles[0], fixed, precision="single")
    assert np.abs(field - hdeform.harmonic_field(V, F, handles[0], fixed)).max() <= 1e-10
    with pytest.raises(ValueError, match="precision"):
        hdeform.Deformer(V, F, fixed, handles, precision="half")


@needs_shared
def test_a_benchmark_case_equals_the_command_line_bit_for_bit(tmp_path):
    base = SHARED / "deformation-benchmark" / "bar"
    files = [f"{base}.obj", f"{base}-fixed.txt", f"{base}-handle.txt", f"{base}-transform.txt"]
    expected = cli_edit(tmp_path, "--mesh", files[0], "--fixed", files[1], "--handle", files[2], "--transform", files[3])
    V, F = hdeform.read_mesh(files[0])
    fixed = np.loadtxt(files[1], dtype=np.int64)
    handle = np.loadtxt(files[2], dtype=np.int64)
    transform = hdeform.Transform(np.loadtxt(files[3]))
    assert np.array_equal(hdeform.Deformer(V, F, fixed, [handle]).deform([transform]), expected)
    # The published labels and matrix give the same.
    labels = np.loadtxt(f"{base}.sel", dtype=np.int64)
    matrix = np.loadtxt(f"{base}.def")
    by_labels = hdeform.Deformer(V, F, np.flatnonzero(labels == 0), [np.flatnonzero(labels == 2)]).deform(matrix)
    assert np.array_equal(by_labels, expected)


def test_fixed_vertices_stay_and_the_handle_follows_a_rigid_motion_exactly():
    bar = hdeform.shape("bar", 16)
    deformer = hdeform.Deformer(bar["V"], bar["F"], bar["fixed"], bar["handles"])
    still = deformer.deform(np.hstack([np.eye(3), np.zeros((3, 1))]))  # nothing moves: the rest shape, to round-off
    assert np.abs(still - bar["V"]).max() <= 1e-9 * np.abs(bar["V"]).max()
    twist = hdeform.Transform.twist(axis=(0, 0, 1), point=(0, 0, 0), degrees=90)
    bent = deformer.deform([twist])
    assert np.array_equal(bent[bar["fixed"]], bar["V"][bar["fixed"]])
    rotation = twist.matrix[:, :3]
    handle = bar["handles"][0]
    assert np.allclose(bent[handle], bar["V"][handle] @ rotation.T + twist.matrix[:, 3], atol=1e-12)


def test_wrong_shapes_and_dtypes_raise_clear_value_errors():
    cactus = hdeform.shape("cactus", 8)
    V, F, fixed, handles = cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]
    cases = [
        ((V.astype(np.int64), F, fixed, handles), "positions must be a float64 array of shape (n, 3); got int64 of shape"),
        ((V[:, :2], F, fixed, handles), "got float64 of shape (" + str(len(V)) + ", 2)"),
        ((V, F.astype(np.float64), fixed, handles), "triangles must be an integer array of shape (m, 3); got float64"),
        ((V, F[:, :2], fixed, handles), "triangles must be an integer array of shape (m, 3)"),
        ((V, F, fixed.astype(np.float32), handles), "fixed must be a 1-D array (or list) of vertex indices; got float32"),
        ((V, F, fixed, handles[0]), "handles[0] must be a 1-D array"),
        (("not an array", F, fixed, handles), "must be a float64 array of shape (n, 3)"),
    ]
    for arguments, fragment in cases:
        with pytest.raises(ValueError) as error:
            hdeform.Deformer(*arguments)
        assert fragment in str(error.value)
    deformer = hdeform.Deformer(V, F, fixed, handles)
    with pytest.raises(ValueError, match=r"must be a Transform or a float array of shape \(3, 4\) or \(4, 4\); got float64 of shape \(2, 2\)"):
        deformer.deform(np.eye(2))
    with pytest.raises(ValueError, match=r"2 transforms for 1 handle$"):
        deformer.deform([np.eye(4), np.eye(4)])
    with pytest.raises(ValueError, match="refine must be"):
        hdeform.Deformer(V, F, fixed, handles, refine="sometimes")


def test_errors_carry_the_command_lines_messages(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    result = run_cli("edit", "--mesh", bad, "--out", tmp_path / "o.obj")
    cli_message = result.stderr.strip().splitlines()[-1].removeprefix("hdeform: error: ")
    with pytest.raises(hdeform.InputError) as error:
        hdeform.read_mesh(bad)
    assert str(error.value) == cli_message
    assert isinstance(error.value, ValueError)
    cactus = hdeform.shape("cactus", 8)
    with pytest.raises(hdeform.InputError, match="out of range"):
        hdeform.Deformer(cactus["V"], cactus["F"], [0, 10**6], cactus["handles"])
    with pytest.raises(hdeform.InputError, match="reflection"):
        hdeform.Transform(np.diag([1.0, 1.0, -1.0, 1.0]))


def test_the_inspection_counts_what_was_added_to_a_clean_mesh():
    cactus = hdeform.shape("cactus")
    V, F = cactus["V"], cactus["F"]
    clean = hdeform.Deformer(V, F, cactus["fixed"], cactus["handles"]).inspection
    assert clean["nonmanifold_edges"] == clean["nonmanifold_vertices"] == clean["unreferenced_vertices"] == 0
    assert clean["components"] == 1
    # A fin on one of the cactus's edges, a vertex in no triangle, and a far copy of the cactus.
    n = len(V)
    a, b = F[0, 0], F[0, 1]
    fin_tip = (V[a] + V[b]) / 2 + [0.0, 0.0, 0.1]
    V2 = np.vstack([V, [fin_tip], [[9.0, 9.0, 9.0]], V + 10.0])
    F2 = np.vstack([F, [[a, b, n]], F + n + 2])
    deformer = hdeform.Deformer(V2, F2, cactus["fixed"], cactus["handles"])
    found = deformer.inspection
    assert found["nonmanifold_edges"] == 1
    assert found["unreferenced_vertices"] == 1
    assert found["components"] == 2
    assert found["boundary_edges"] == clean["boundary_edges"] * 2 + 2  # the fin's two free edges
    assert "1 non-manifold edge (shared by more than two triangles)" in deformer.warnings
    assert "1 unreferenced vertex (in no triangle) stays in place" in deformer.warnings


def test_the_gil_is_released_while_solving():
    big = hdeform.shape("cactus", 200)  # about 200,000 triangles
    counted = 0
    done = threading.Event()

    def count():
        nonlocal counted
        while not done.is_set():
            counted += 1

    counter = threading.Thread(target=count)
    counter.start()
    time.sleep(0.05)
    before = counted
    start = time.perf_counter()
    deformer = hdeform.Deformer(big["V"], big["F"], big["fixed"], big["handles"])
    deformer.deform([big["transform"]])
    seconds = time.perf_counter() - start
    during = counted - before
    done.set()
    counter.join()
    # With the GIL held the counting thread would get a turn only every switch interval (5 ms):
    # a few hundred increments. Released, it counts all along.
    assert seconds > 0.1
    assert during > 200_000 * seconds, f"{during} increments in {seconds:.2f} s"


def test_the_laplacian_is_symmetric_with_zero_row_sums_and_positive_semidefinite():
    scipy_sparse = pytest.importorskip("scipy.sparse")
    sphere = hdeform.shape("sphere", 12)
    L = hdeform.cotangent_laplacian(sphere["V"], sphere["F"])
    assert scipy_sparse.issparse(L) and L.shape == (len(sphere["V"]),) * 2
    assert abs(L - L.T).max() == 0.0
    assert np.abs(np.asarray(L.sum(axis=1))).max() < 1e-12
    x = np.random.default_rng(1).standard_normal(len(sphere["V"]))
    assert x @ (L @ x) > 0.0


def test_the_harmonic_field_obeys_the_maximum_principle_and_matches_the_deformers():
    cactus = hdeform.shape("cactus", 16)
    h = hdeform.harmonic_field(cactus["V"], cactus["F"], cactus["handles"][0], cactus["fixed"])
    assert h.shape == (len(cactus["V"]),)
    assert h.min() >= 0.0 and h.max() <= 1.0
    assert np.all(h[cactus["handles"][0]] == 1.0) and np.all(h[cactus["fixed"]] == 0.0)
    assert np.array_equal(h, hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]).field)


@pytest.mark.parametrize("method", ["correspondence", "interpolation"])
def test_transferring_the_rest_pose_onto_the_same_mesh_gives_the_rest_mesh(method):
    cactus = hdeform.shape("cactus", 16)
    V, F = cactus["V"], cactus["F"]
    chosen = np.linspace(0, len(V) - 1, 7).astype(np.int64)
    markers = np.column_stack([chosen, chosen])
    (result,) = hdeform.transfer((V, F), [V], (V, F), markers, method=method)
    assert np.abs(result - V).max() < 1e-9 * np.abs(V).max()


def test_a_mesh_corresponds_to_itself():
    sphere = hdeform.shape("sphere", 12)
    chosen = np.arange(0, len(sphere["V"]), len(sphere["V"]) // 8)[:8]
    source, distance, mismatch = hdeform.correspondence((sphere["V"], sphere["F"]), (sphere["V"], sphere["F"]), np.column_stack([chosen, chosen]))
    assert np.array_equal(source, np.arange(len(sphere["F"])))
    assert distance.max() == 0.0 and not mismatch.any()


def triangle_areas(V, F):
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)


def test_subdivision_splits_each_triangle_at_its_midpoints_and_carries_the_sets():
    cactus = hdeform.shape("cactus", 16)
    V, F, fixed, handle = cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"][0]
    edges = {tuple(sorted((int(a), int(b)))) for t in F for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    V2, F2, (fixed2, handle2) = hdeform.subdivide(V, F, levels=1, sets=[fixed, handle])
    assert len(V2) == len(V) + len(edges) and len(F2) == 4 * len(F)
    assert np.array_equal(V2[: len(V)], V), "the original vertices keep their positions and indices"
    # Triangle t becomes (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca).
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    ab, bc, ca = F2[1::4, 0], F2[1::4, 2], F2[0::4, 2]
    for middle, (p, q) in ((ab, (a, b)), (bc, (b, c)), (ca, (c, a))):
        assert np.allclose(V2[middle], 0.5 * (V[p] + V[q]), rtol=0, atol=1e-15)
    assert np.allclose(triangle_areas(V2, F2).reshape(-1, 4).sum(axis=1), triangle_areas(V, F), rtol=1e-12)
    for original, carried in ((fixed, fixed2), (handle, handle2)):
        member = np.zeros(len(V2), bool)
        member[original] = True
        for middle, (p, q) in ((ab, (a, b)), (bc, (b, c)), (ca, (c, a))):
            expected = member[p] & member[q]
            assert np.array_equal(np.isin(middle, carried), expected), "a new vertex is in a set where both ends of its edge are"
        assert carried.dtype == np.int32 and set(original) <= set(carried)
    V3, F3, _ = hdeform.subdivide(V, F, levels=2)
    assert len(F3) == 16 * len(F)
    V0, F0, (same,) = hdeform.subdivide(V, F, levels=0, sets=[fixed])
    assert np.array_equal(V0, V) and np.array_equal(F0, F) and np.array_equal(same, fixed)
    with pytest.raises(ValueError, match="levels"):
        hdeform.subdivide(V, F, levels=5)
    with pytest.raises(hdeform.InputError, match=r"sets\[1\]: vertex 99999 out of range"):
        hdeform.subdivide(V, F, sets=[fixed, [99999]])


def test_relief_moves_vertices_along_the_normal_by_at_most_its_amplitude():
    sphere = hdeform.shape("sphere", 32)
    V, F = sphere["V"], sphere["F"]
    assert np.array_equal(hdeform.add_relief(V, F, 0.0), V)
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    moved = hdeform.add_relief(V, F, 0.01)
    offset = moved - V
    length = np.linalg.norm(offset, axis=1)
    assert length.max() <= 1.75 * 0.01 * diagonal and length.max() > 0.5 * 0.01 * diagonal
    # On a sphere about its centre the normal is radial: the offset lies along the radius.
    radial = V - V.mean(axis=0)
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    along = np.abs(np.einsum("ij,ij->i", offset, radial))
    assert np.allclose(along, length, rtol=0, atol=1e-3 * 0.01 * diagonal)
    with pytest.raises(hdeform.InputError, match="amplitude"):
        hdeform.add_relief(V, F, -0.001)


def test_meshes_round_trip_through_obj_and_ply(tmp_path):
    bar = hdeform.shape("bar", 12)
    for name in ["bar.obj", "bar.ply"]:
        hdeform.write_mesh(tmp_path / name, bar["V"], bar["F"])
        V, F = hdeform.read_mesh(tmp_path / name)
        assert np.array_equal(F, bar["F"])
        assert np.array_equal(V, bar["V"])  # both formats are written and read in double precision
    with pytest.raises(hdeform.InputError, match=r"meshes are written as \.obj or \.ply"):
        hdeform.write_mesh(tmp_path / "bar.stl", bar["V"], bar["F"])
    assert not (tmp_path / "bar.stl").exists()


def test_outputs_are_numpy_arrays_that_own_the_solvers_matrices():
    cactus = hdeform.shape("cactus", 8)
    bent = hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"]).deform([cactus["transform"]])
    assert bent.dtype == np.float64 and bent.shape == cactus["V"].shape
    assert bent.flags["F_CONTIGUOUS"] and not bent.flags["OWNDATA"]  # a view of the solver's matrix, not a copy


def test_a_result_dropped_lends_its_memory_to_the_next_and_one_kept_is_never_overwritten():
    cactus = hdeform.shape("cactus", 8)
    deformer = hdeform.Deformer(cactus["V"], cactus["F"], cactus["fixed"], cactus["handles"], refine=0)
    twist = cactus["transform"]

    def address(array):
        return array.__array_interface__["data"][0]

    first = deformer.deform([twist])
    kept = first.copy()
    second = deformer.deform([np.eye(4)[:3]])  # first is still held: new memory
    assert address(second) != address(first)
    assert np.array_equal(first, kept), "a result still held was overwritten"
    assert np.array_equal(second, cactus["V"]), "the rest pose gives the rest shape"
    reused = address(first)
    del first  # dropped: its memory serves the next result, which is still exact
    third = deformer.deform([twist])
    assert address(third) == reused
    assert np.array_equal(third, kept)
    del second
    refined = deformer.refine(2)  # refine() takes its arrays from the same place
    assert refined.flags["F_CONTIGUOUS"] and np.isfinite(refined).all()
    assert np.array_equal(third, kept)
    del deformer  # a result outliving its deformer stays valid
    assert np.array_equal(third, kept)


@pytest.mark.skipif(not hdeform.has_render, reason="built without the engine")
def test_render_writes_a_png_of_the_requested_size(tmp_path):
    cactus = hdeform.shape("cactus", 12)
    path = tmp_path / "cactus.png"
    hdeform.render(cactus["V"], cactus["F"], path, field=np.linspace(0, 1, len(cactus["V"])), size="320x240")
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">II", header[16:24]) == (320, 240)


@needs_shared
def test_the_readme_example_bends_the_buddha(tmp_path):
    example = SOURCE_DIR / "python" / "examples" / "bend_buddha.py"
    result = subprocess.run([sys.executable, example, SHARED / "buddha", tmp_path], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert "refinement iterations" in result.stdout
    V, F = hdeform.read_mesh(tmp_path / "buddha-bent.ply")
    assert len(V) == 102818
