"""The Hierarchy choice (Full, Relevant, Minimal) of Adaptive Isosurface and Adaptive Interval Volume
(Weiss & De Floriani's isodiamond hierarchies), checked against Full with numpy:

- at every tested rung of the ladder (field data HierarchyLadder) Relevant and Minimal give Full's
  surface / tetrahedra at that Tolerance: the same points in the same order (points are numbered by
  their mesh edge), each within 1/512 of the image diagonal of Full's (crossings are stored to 1/256
  of their edge), and the same triangles (same orientation) / the same tetrahedra; between two rungs,
  Full's at the finer rung; ErrorBound is the rung's tolerance;
- Relevant and Minimal surfaces are watertight and oriented (`diamonds verify-surface`); their normals
  are unit length and agree with Full's gradient normals; interval-volume points carry the input
  arrays, the processed one within 1/512 of the data range of a bound at new points;
- HierarchyMemorySize in field data for all three choices; on a real volume (hydrogen orbital 64^3,
  float) the isosurface's Relevant and Minimal below Full (in memory MI is not always below RI: its
  orphan vertices can outweigh the relevant isodiamonds it leaves out); changing the isovalue or range rebuilds the isodiamond
  hierarchy (NumberOfIsodiamondBuilds), changing Tolerance or the budget does not, and the rebuilt
  one equals Full at the new value;
- the budget picks the finest rung that fits;
- bad combinations (several contour values, a region of interest, carrier tetrahedra) give a clear
  error and an empty output;
- AbortExecute during the isodiamond build (progress reported per rung) gives an empty output, no
  error, and nothing kept; the next update builds it.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_hierarchy_choice.py
"""

import os
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from isosurface_checks import surface_arrays, verify_surface  # noqa: E402

simple = dc.require_plugin()
CHOICES = ("Relevant", "Minimal")


def ladder(data):
    a = data.GetFieldData().GetArray("HierarchyLadder")
    return None if a is None else vtk_to_numpy(a).astype(np.float64)


def isodiamond_builds(proxy):
    proxy.UpdatePropertyInformation()
    return int(proxy.GetProperty("NumberOfIsodiamondBuilds").GetElement(0))


def moved(points, reference):
    """Largest distance between corresponding points (the extraction numbers points by their mesh
    edge, so the same edges give the same order), or inf when the counts differ."""
    if len(points) != len(reference):
        return float("inf")
    return float(np.linalg.norm(points - reference, axis=1).max()) if len(points) else 0.0


def canonical_triangles(tris):
    """Each triangle rotated to start at its smallest id (orientation kept), rows sorted."""
    r = np.argmin(tris, axis=1)
    rolled = np.stack([tris[np.arange(len(tris)), (r + k) % 3] for k in range(3)], axis=1)
    return rolled[np.lexsort(rolled.T[::-1])]


def canonical_tets(tets):
    s = np.sort(tets, axis=1)
    return s[np.lexsort(s.T[::-1])]


def same_as_full(full, other, bound, label, surface):
    """`other` has `full`'s cells on `full`'s points, moved by at most `bound`."""
    if surface:
        pf, cf = surface_arrays(full)
        po, co = surface_arrays(other)
        canon = canonical_triangles
    else:
        pf, cf, _ = dc.mesh_arrays(full)
        po, co, _ = dc.mesh_arrays(other)
        canon = canonical_tets
    far = moved(po, pf)
    cells = 0 if cf is None else len(cf)
    same = far <= bound and co is not None and cf is not None and co.shape == cf.shape
    same = same and np.array_equal(canon(co), canon(cf))
    dc.check(cells > 0 and same, f"{label}: {cells} cells, the same as Full's on the same points (farthest {far:.3g} <= {bound:.3g})")


def run(proxy):
    with dc.ErrorCapture(proxy) as errors:
        data = dc.fetch(proxy)
    return data, errors.text()


def image_of(source):
    image = dc.fetch(source)
    spacing = np.array(image.GetSpacing())
    # Crossings are stored to 1/256 of their edge (at most 1/512 away); an edge of the finest mesh is
    # at most a cell diagonal, of the coarse tetrahedra at most the image diagonal.
    diagonal = float(np.linalg.norm((np.array(image.GetDimensions()) - 1) * spacing))
    return image, diagonal / 512.0 * 1.01


def compare_isosurfaces(source, array, iso, label, rungs):
    image, bound = image_of(source)
    full = simple.AdaptiveIsosurface(Input=source, ContourBy=["POINTS", array], Isosurfaces=[iso], Hierarchy="Full")
    filters = {h: simple.AdaptiveIsosurface(Input=source, ContourBy=["POINTS", array], Isosurfaces=[iso], Hierarchy=h) for h in CHOICES}
    memory = {}
    steps = None
    for k in rungs:
        for h, f in filters.items():
            f.Tolerance = 0.0 if steps is None else float(steps[k])
            data, text = run(f)
            if steps is None:
                steps = ladder(data)
                dc.check(steps is not None and len(steps) == 8 and steps[-1] == 0.0 and (np.diff(steps) < 0).all(), f"{label}: {h} reports its ladder of 8 rungs ending at 0 ({steps})")
                f.Tolerance = float(steps[k])
                data, text = run(f)
            full.Tolerance = float(steps[k])
            reference = dc.fetch(full)
            same_as_full(reference, data, bound, f"{label} {h} at rung {k} (tolerance {steps[k]:.4g})", surface=True)
            dc.check(dc.field_value(data, "ErrorBound") == steps[k], f"{label} {h} rung {k}: ErrorBound is the rung's tolerance")
            memory[h] = dc.field_value(data, "HierarchyMemorySize")
            if k == rungs[0]:
                verify_surface(image, data, closed=False)
                n = vtk_to_numpy(data.GetPointData().GetNormals()).astype(np.float64)
                unit = np.abs(np.linalg.norm(n, axis=1) - 1.0).max() < 1e-5
                # Full's normals are the gradient's: the surface's own agree with them on most points.
                g = vtk_to_numpy(reference.GetPointData().GetNormals()).astype(np.float64)
                agree = float(np.mean(np.einsum("ij,ij->i", n, g) > 0.5))
                dc.check(unit and agree > 0.9, f"{label} {h}: unit normals, {100 * agree:.1f} % within 60 degrees of Full's gradient normals")
    memory["Full"] = dc.field_value(dc.fetch(full), "HierarchyMemorySize")
    # Between two rungs: the finer rung's surface.
    k = rungs[0]
    f = filters["Minimal"]
    f.Tolerance = float(0.5 * (steps[k] + steps[k + 1]))
    full.Tolerance = float(steps[k + 1])
    same_as_full(dc.fetch(full), dc.fetch(f), bound, f"{label} Minimal between rungs {k} and {k + 1}: the finer rung's", surface=True)
    for p in [full, *filters.values()]:
        simple.Delete(p)
    return memory, steps


def compare_interval_volumes(source, array, rng, label, rungs):
    image, bound = image_of(source)
    span = image.GetPointData().GetArray(array).GetRange()
    full = simple.AdaptiveIntervalVolume(Input=source, Scalars=["POINTS", array], ThresholdRange=rng, Hierarchy="Full")
    filters = {h: simple.AdaptiveIntervalVolume(Input=source, Scalars=["POINTS", array], ThresholdRange=rng, Hierarchy=h) for h in CHOICES}
    memory = {}
    steps = ladder(dc.fetch(filters["Relevant"]))
    dc.check(steps is not None and len(steps) == 8 and steps[-1] == 0.0, f"{label}: the ladder in field data ({steps})")
    for k in rungs:
        full.Tolerance = float(steps[k])
        reference = dc.fetch(full)
        for h, f in filters.items():
            f.Tolerance = float(steps[k])
            data = dc.fetch(f)
            same_as_full(reference, data, bound, f"{label} {h} at rung {k} (tolerance {steps[k]:.4g})", surface=False)
            dc.check(dc.field_value(data, "ReachedTolerance") == steps[k] and dc.field_value(data, "ErrorBound") == steps[k], f"{label} {h} rung {k}: ReachedTolerance and ErrorBound are the rung's tolerance")
            memory[h] = dc.field_value(data, "HierarchyMemorySize")
            # Input arrays interpolated at the stored crossings: within 1/512 of the edge's value
            # difference (at most the data range) of a bound.
            values = data.GetPointData().GetArray(array)
            v = vtk_to_numpy(values).astype(np.float64) if values is not None else np.zeros(0)
            slack = (span[1] - span[0]) / 512.0 * 1.01
            inside = ((v >= rng[0] - slack) & (v <= rng[1] + slack)).all()
            dc.check(values is not None and len(v) == data.GetNumberOfPoints() and inside, f"{label} {h} rung {k}: '{array}' carried, every value in the range within {slack:.3g}")
    memory["Full"] = dc.field_value(dc.fetch(full), "HierarchyMemorySize")
    k = rungs[0]
    f = filters["Relevant"]
    f.Tolerance = float(0.5 * (steps[k] + steps[k + 1]))
    full.Tolerance = float(steps[k + 1])
    same_as_full(dc.fetch(full), dc.fetch(f), bound, f"{label} Relevant between rungs {k} and {k + 1}: the finer rung's", surface=False)
    for p in [full, *filters.values()]:
        simple.Delete(p)
    return memory


# ---- A generated volume: Wavelet 41^3 (float RTData).
wavelet = simple.Wavelet(WholeExtent=[-20, 20, -20, 20, -20, 20])
compare_isosurfaces(wavelet, "RTData", 157.0, "Wavelet isosurface 157", rungs=(2, 4, 7))
compare_interval_volumes(wavelet, "RTData", [130.0, 180.0], "Wavelet interval [130, 180]", rungs=(2, 4, 7))

# ---- A real volume: memory Minimal < Relevant < Full.
path = dc.shared_path("data/volumes/hydrogen_orbital_64x64x64_float32.vti")
if path:
    reader = simple.XMLImageDataReader(FileName=path)
    memory, _ = compare_isosurfaces(reader, "probability_density", 0.05, "hydrogen isosurface 0.05", rungs=(3, 7))
    # In memory (hash index, sorted crossings and orphan classes) RI and MI are not ordered in general:
    # MI's orphan vertices can outweigh the relevant isodiamonds it leaves out. Both are below the float
    # samples and caches of Full for a surface.
    dc.check(0 < max(memory["Minimal"], memory["Relevant"]) < memory["Full"], f"hydrogen isosurface HierarchyMemorySize: Minimal {memory['Minimal']:.0f} and Relevant {memory['Relevant']:.0f} < Full {memory['Full']:.0f} bytes")
    memory = compare_interval_volumes(reader, "probability_density", [0.05, 0.2], "hydrogen interval [0.05, 0.2]", rungs=(3, 7))
    dc.check(min(memory.values()) > 0, f"hydrogen interval volume HierarchyMemorySize reported: Minimal {memory['Minimal']:.0f}, Relevant {memory['Relevant']:.0f}, Full {memory['Full']:.0f} bytes")

# ---- The isodiamond hierarchy is kept: rebuilt for a new isovalue or range, not for a new Tolerance.
iso = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[157.0], Hierarchy="Minimal", Tolerance=0.0)
steps = ladder(dc.fetch(iso))
for t in steps[:4]:
    iso.Tolerance = float(t)
    dc.fetch(iso)
iso.MaximumNumberOfTriangles = 10
dc.fetch(iso)
iso.MaximumNumberOfTriangles = 0
dc.check(isodiamond_builds(iso) == 1 and dc.hierarchy_builds(iso) == 1, f"five tolerances and a budget: one isodiamond build ({isodiamond_builds(iso)})")
iso.Isosurfaces = [120.0]
iso.Tolerance = float(steps[3])
changed = dc.fetch(iso)
reference = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[120.0], Hierarchy="Full", Tolerance=float(steps[3]))
dc.check(isodiamond_builds(iso) == 2 and dc.hierarchy_builds(iso) == 1, "a new isovalue rebuilds the isodiamond hierarchy, not the diamond hierarchy")
same_as_full(dc.fetch(reference), changed, image_of(wavelet)[1], "isovalue 120 after the change", surface=True)
iso.Hierarchy = "Relevant"
dc.fetch(iso)
dc.check(isodiamond_builds(iso) == 3, "a change from Minimal to Relevant rebuilds it")
iso.Hierarchy = "Full"
full_data = dc.fetch(iso)
dc.check(ladder(full_data) is None and dc.field_value(full_data, "HierarchyMemorySize") > 0, "Full: no ladder, HierarchyMemorySize in field data")

interval = simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[130.0, 180.0], Hierarchy="Relevant", Tolerance=0.0)
dc.fetch(interval)
interval.Tolerance = float(steps[2])
dc.fetch(interval)
dc.check(isodiamond_builds(interval) == 1, "interval volume: a Tolerance change keeps the isodiamond hierarchy")
interval.ThresholdRange = [140.0, 180.0]
dc.fetch(interval)
dc.check(isodiamond_builds(interval) == 2 and dc.hierarchy_builds(interval) == 1, "a new range rebuilds the isodiamond hierarchy only")

# ---- The budget: the finest rung at or above Tolerance that fits.
iso.Hierarchy = "Minimal"
iso.Isosurfaces = [157.0]
iso.Tolerance = 0.0
counts = []
for t in steps:
    iso.Tolerance = float(t)
    counts.append(dc.fetch(iso).GetNumberOfCells())
iso.Tolerance = 0.0
iso.MaximumNumberOfTriangles = counts[4] + 1
budget = dc.fetch(iso)
iso.MaximumNumberOfTriangles = 0
dc.check(budget.GetNumberOfCells() == counts[4] and dc.field_value(budget, "ErrorBound") == steps[4], f"budget {counts[4] + 1} at Tolerance 0: rung 4's {counts[4]} triangles (counts per rung {counts})")
interval.ThresholdRange = [130.0, 180.0]
interval.Tolerance = 0.0
tets = []
for t in steps:
    interval.Tolerance = float(t)
    tets.append(dc.fetch(interval).GetNumberOfCells())
interval.Tolerance = 0.0
interval.MaximumNumberOfTetrahedra = tets[3]
budget = dc.fetch(interval)
interval.MaximumNumberOfTetrahedra = 0
dc.check(budget.GetNumberOfCells() == tets[3] and dc.field_value(budget, "ReachedTolerance") == steps[3], f"interval budget {tets[3]}: rung 3's tetrahedra ({tets})")

# ---- Bad combinations: a clear error, an empty output.
for label, changes, phrase in [
    ("two contour values", {"Isosurfaces": [130.0, 157.0]}, "one isosurface"),
    ("a region of interest", {"UseRegionOfInterest": 1, "RegionOfInterest": [-5, 5, -5, 5, -5, 5]}, "region of interest"),
    ("carrier tetrahedra", {"GenerateCarrierTetrahedra": 1}, "carrier tetrahedra"),
]:
    f = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[157.0], Hierarchy="Relevant", Tolerance=1.0)
    for name, value in changes.items():
        setattr(f, name, value)
    data, text = run(f)
    print(f"   [{label}] {text.strip().splitlines()[-1] if text.strip() else '(no message)'}")
    dc.check(phrase in text and data.GetNumberOfCells() == 0, f"isosurface, Relevant with {label}: error mentions {phrase!r}, empty output")
    # Refused before the isodiamond hierarchy is built: the user does not wait for a useless build.
    dc.check(isodiamond_builds(f) == 0, f"isosurface, Relevant with {label}: refused before any isodiamond build ({isodiamond_builds(f)})")
    simple.Delete(f)
f = simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[130.0, 180.0], Hierarchy="Minimal", UseRegionOfInterest=1, RegionOfInterest=[-5, 5, -5, 5, -5, 5])
data, text = run(f)
dc.check("region of interest" in text and data.GetNumberOfCells() == 0, f"interval volume, Minimal with a region of interest: a clear error, empty output ({text.strip().splitlines()[-1] if text.strip() else ''})")
dc.check(isodiamond_builds(f) == 0, f"interval volume, Minimal with a region of interest: refused before any isodiamond build ({isodiamond_builds(f)})")

# ---- An isovalue or range missing the data: an empty output and a warning, as with Full.
for choice in CHOICES:
    for label, f in (("isosurface 1000", simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[1000.0], Hierarchy=choice)),
                     ("interval volume [500, 600]", simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[500.0, 600.0], Hierarchy=choice))):
        data, text = run(f)
        dc.check("misses the data range" in text and data.GetNumberOfCells() == 0, f"{label}, {choice}, outside the data: empty output, a warning ({text.strip().splitlines()[-1] if text.strip() else ''})")
        simple.Delete(f)

# ---- Abort during the isodiamond build: the diamond hierarchy is built first (Full), then the
# observer sets AbortExecute at the first progress report of the isodiamond build (progress strictly
# inside its share of the filter's progress): empty output, no error, nothing kept or counted; the
# next update (another rung) builds it and gives Full's mesh.
for make, window, what in (
    (lambda h: simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=[157.0], Hierarchy=h, Tolerance=float(steps[3])), (0.7, 0.75), "isosurface"),
    (lambda h: simple.AdaptiveIntervalVolume(Input=wavelet, ThresholdRange=[130.0, 180.0], Hierarchy=h, Tolerance=float(steps[3])), (0.3, 0.5), "interval volume"),
):
    for choice in CHOICES:
        f = make("Full")
        f.Tolerance = float(steps[2])
        reference = dc.fetch(f)
        f.Tolerance = float(steps[3])
        f.Hierarchy = choice
        vtk_filter = f.GetClientSideObject()
        seen = []

        def abort_in_build(obj, _event, seen=seen, window=window):
            p = obj.GetProgress()
            if window[0] < p < window[1]:
                seen.append(p)
                obj.SetAbortExecute(1)

        tag = vtk_filter.AddObserver("ProgressEvent", abort_in_build)
        aborted, text = run(f)
        vtk_filter.RemoveObserver(tag)
        vtk_filter.SetAbortExecute(0)
        dc.check(len(seen) == 1 and aborted.GetNumberOfCells() == 0 and not text.strip(), f"{what}, {choice}: AbortExecute at progress {seen} during the isodiamond build gives an empty output and no error ({text.strip()!r})")
        dc.check(isodiamond_builds(f) == 0 and dc.hierarchy_builds(f) == 1, f"{what}, {choice}: the aborted build is not counted or kept ({isodiamond_builds(f)} builds)")
        f.Tolerance = float(steps[2])
        after = dc.fetch(f)
        dc.check(isodiamond_builds(f) == 1, f"{what}, {choice}: the next update builds the isodiamond hierarchy")
        same_as_full(reference, after, image_of(wavelet)[1], f"{what}, {choice} after an aborted build", surface=what == "isosurface")
        simple.Delete(f)

doc = simple.AdaptiveIsosurface(Input=wavelet).GetProperty("Hierarchy")
dc.check(doc is not None and "rung" in (doc.GetDocumentation().GetDescription() or ""), "the Hierarchy property is documented (the ladder)")
dc.finish("test_hierarchy_choice")
