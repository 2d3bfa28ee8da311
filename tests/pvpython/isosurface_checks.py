"""Independent checks of an isosurface (vtkPolyData) against the image it was extracted from, shared by
test_isosurface.py and mpi_isosurface.py. numpy only; VTK hands over the arrays, and
vtkDistancePolyDataFilter measures distances to a reference surface (ParaView's Contour).

- only triangles, corners index existing points, every point inside the image bounds;
- watertight and consistently oriented, by the one implementation of that check (the Rust core's
  `diamonds::validate::check_surface`): the surface and the image are saved and `diamonds
  verify-surface` runs on them: triangles of three distinct points, every edge in exactly two triangles,
  once in each direction, except edges whose two ends lie on the same face of the image box (then in
  one; not at all when closed), unit normals; optionally closed with one genus-0 component
  (V - E + F = 2);
- the triangles face increasing values (trilinear interpolation of the samples on both sides of each
  triangle), normals unit length and on the same side;
- field data ErrorBound, NumberOfTriangles, Tolerance, RelativeTolerance;
- every vertex within the tolerance plus a voxel diagonal of a reference surface.
"""

import math
import os
import subprocess
import tempfile

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkFiltersGeneral import vtkDistancePolyDataFilter
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLPolyDataWriter

import diamonds_checks as dc

VTK_TRIANGLE = 5


def surface_arrays(poly):
    """Points (N,3) and triangles (M,3) of a vtkPolyData made of triangles only (None otherwise)."""
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64) if poly.GetPoints() else np.zeros((0, 3))
    polys = poly.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray()).astype(np.int64)
    conn = vtk_to_numpy(polys.GetConnectivityArray()).astype(np.int64)
    if len(offsets) > 1 and not (np.diff(offsets) == 3).all():
        return points, None
    return points, conn.reshape(-1, 3)


def verify_surface(image, poly, closed):
    """Runs `diamonds verify-surface` on `poly` saved as .vtp, open only on the faces of `image`'s box
    (saved as .vti) unless `closed`. Returns (passed, the CLI's report)."""
    with tempfile.TemporaryDirectory() as tmp:
        surface_path = os.path.join(tmp, "surface.vtp")
        args = [dc.diamonds_binary(), "verify-surface", surface_path]
        writers = [(vtkXMLPolyDataWriter(), poly, surface_path)]
        if not closed:
            image_path = os.path.join(tmp, "image.vti")
            args += ["--image", image_path]
            writers.append((vtkXMLImageDataWriter(), image, image_path))
        for writer, data, path in writers:
            writer.SetInputData(data)
            writer.SetFileName(path)
            if not writer.Write():
                return False, f"could not write {path}"
        run = subprocess.run(args, capture_output=True, text=True)
        return run.returncode == 0, (run.stdout + run.stderr).strip()


def components(n_points, tris):
    """Number of connected components of the triangles (union-find over shared vertices)."""
    parent = np.arange(n_points)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b, c in tris:
        ra, rb, rc = find(a), find(b), find(c)
        parent[rb] = ra
        parent[find(rc)] = ra
    used = np.unique(tris)
    return len({find(p) for p in used})


def trilinear(image, scalars, x):
    """Trilinear interpolation of a point array of `image` at world points `x` (clamped inside)."""
    dims = np.array(image.GetDimensions())
    origin = np.array(image.GetOrigin()) + np.array(image.GetExtent())[0::2] * np.array(image.GetSpacing())
    f = vtk_to_numpy(image.GetPointData().GetArray(scalars)).astype(np.float64).reshape(dims[::-1])  # z, y, x
    u = np.clip((x - origin) / np.array(image.GetSpacing()), 0, dims - 1 - 1e-9)
    i0 = np.floor(u).astype(np.int64)
    t = u - i0
    out = np.zeros(len(x))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = (t[:, 0] if dx else 1 - t[:, 0]) * (t[:, 1] if dy else 1 - t[:, 1]) * (t[:, 2] if dz else 1 - t[:, 2])
                out += w * f[i0[:, 2] + dz, i0[:, 1] + dy, i0[:, 0] + dx]
    return out


def check_surface(
    image, poly, scalars, tolerance, label, closed=False, reference=None, check_normals=True, error_limit=None, whole_bounds=None
):
    """Every independent check of one output surface over `image` (a piece of the whole image in
    parallel runs, `whole_bounds` then giving the whole); returns the number of triangles.

    `error_limit`: what ErrorBound may reach (default `tolerance`; infinite with a region of
    interest, which leaves the rest of the surface coarse)."""
    error_limit = tolerance if error_limit is None else error_limit
    reach = error_limit  # how far the surface may be from the full-resolution one
    points, tris = surface_arrays(poly)
    n = poly.GetNumberOfCells()
    dc.check(n > 0, f"{label}: {n} triangles, {len(points)} points")
    if n == 0:
        return 0
    types = {poly.GetCellType(i) for i in range(0, n, max(1, n // 1000))}
    dc.check(
        tris is not None and types == {VTK_TRIANGLE} and poly.GetNumberOfVerts() == 0 and poly.GetNumberOfLines() == 0 and poly.GetNumberOfStrips() == 0,
        f"{label}: only triangles",
    )
    if tris is None:
        return n
    dc.check(tris.min() >= 0 and tris.max() < len(points), f"{label}: triangle corners index existing points")
    spacing = np.array(image.GetSpacing())
    voxel = float(np.linalg.norm(spacing))
    bounds = np.array(image.GetBounds())
    eps = 1e-9 * max(1.0, np.abs(bounds).max())
    dc.check(
        (points.min(0) >= bounds[0::2] - eps).all() and (points.max(0) <= bounds[1::2] + eps).all(),
        f"{label}: every point inside the image bounds",
    )

    # Watertight and consistently oriented (closed: without an edge on the image boundary).
    passed, report = verify_surface(image, poly, closed)
    dc.check(passed, f"{label}: diamonds verify-surface{' (closed)' if closed else ''}: watertight, consistently oriented" + ("" if passed else "\n" + report))
    if closed:
        # Every edge in two triangles (verified): E = 3F / 2.
        euler = len(np.unique(tris)) - len(tris) // 2
        dc.check(euler == 2 and components(len(points), tris) == 1, f"{label}: one genus-0 component (V - E + F = {euler})")

    # Orientation: the samples increase along the face normal (trilinear interpolation, a quarter
    # voxel diagonal on each side of the centroid). The triangles are oriented by the linear
    # interpolant of their tetrahedron, not by this trilinear field: small faces and, above a voxel of
    # tolerance, faces tilted by the coarsening can disagree. Orientation is consistent along every
    # edge (checked above), so a clear majority here means every component faces the right way.
    # Without a bound (outside a region of interest) a coarse surface can be far off: no majority
    # asked there.
    majority = 0.97 if reach <= voxel else 0.85 if math.isfinite(reach) else 0.0
    p = points[tris]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(fn, axis=1)
    ok = area2 > 1e-12 * voxel * voxel
    fn = fn[ok] / area2[ok, None]
    c = p[ok].mean(1)
    h = 0.25 * voxel
    rise = trilinear(image, scalars, c + h * fn) - trilinear(image, scalars, c - h * fn)
    share = float((rise > 0).mean())
    dc.check(share > majority, f"{label}: triangles face increasing values ({100 * share:.2f} %)")

    # Normals.
    normals = poly.GetPointData().GetNormals()
    if check_normals:
        dc.check(normals is not None and normals.GetName() == "Normals" and normals.GetNumberOfComponents() == 3, f"{label}: point normals 'Normals'")
        if normals is not None:
            nv = vtk_to_numpy(normals).astype(np.float64)
            length = np.linalg.norm(nv, axis=1)
            dc.check(np.abs(length - 1).max() < 1e-4, f"{label}: unit normals (|n| in [{length.min():.6f}, {length.max():.6f}])")
            agree = float(((nv[tris[ok]].mean(1) * fn).sum(1) > 0).mean())
            dc.check(agree > majority, f"{label}: normals on the side the triangles face ({100 * agree:.2f} %)")

    # Field data.
    error_bound = dc.field_value(poly, "ErrorBound")
    dc.check(error_bound is not None and 0 <= error_bound <= error_limit * (1 + 1e-9), f"{label}: ErrorBound {error_bound} <= {error_limit:g}")
    dc.check(dc.field_value(poly, "NumberOfTriangles") == n, f"{label}: field data NumberOfTriangles == {n}")
    dc.check(dc.field_value(poly, "Tolerance") == tolerance, f"{label}: field data Tolerance == {tolerance:g}")
    whole = bounds if whole_bounds is None else np.asarray(whole_bounds, dtype=np.float64)
    diagonal = float(np.linalg.norm(whole[1::2] - whole[0::2]))
    rel = dc.field_value(poly, "RelativeTolerance")
    dc.check(rel is not None and abs(rel - tolerance / diagonal) <= 1e-12, f"{label}: field data RelativeTolerance == Tolerance / diagonal ({rel})")

    # Distance to the reference (ParaView's Contour of the same isovalue).
    if reference is not None and math.isfinite(reach):
        d = distances(poly, reference)
        dc.check(d.max() <= reach + voxel, f"{label}: every vertex within {reach:.4g} + a voxel diagonal of Contour (max {d.max():.4g} <= {reach + voxel:.4g})")
    return n


def distances(poly, reference):
    """Unsigned distance from every point of `poly` to the surface `reference`."""
    f = vtkDistancePolyDataFilter()
    f.SetInputData(0, poly)
    f.SetInputData(1, reference)
    f.SignedDistanceOff()
    f.ComputeSecondDistanceOff()
    f.Update()
    return np.abs(vtk_to_numpy(f.GetOutput().GetPointData().GetArray("Distance")))


def same_surface(a, b):
    pa, ta = surface_arrays(a)
    pb, tb = surface_arrays(b)
    return pa.shape == pb.shape and ta.shape == tb.shape and np.array_equal(pa, pb) and np.array_equal(ta, tb)
