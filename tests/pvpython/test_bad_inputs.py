"""Bad inputs and parameters: each must produce a clear error (or, for 64-bit integers, a warning
and a valid mesh), an empty output, and no crash. Also: AbortExecute interrupts the build.

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds pvpython tests/pvpython/test_bad_inputs.py
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402

simple = dc.require_plugin()


def expect_error(filt, phrase, label):
    """Runs `filt`; the error must mention `phrase` (or one of several phrases) and the output must
    be empty."""
    phrases = phrase if isinstance(phrase, tuple) else (phrase,)
    with dc.ErrorCapture(filt) as errors:
        out = dc.fetch(filt)
    text = errors.text()
    print(f"   [{label}] {text.strip().splitlines()[-1] if text.strip() else '(no message)'}")
    dc.check(any(p.lower() in text.lower() for p in phrases), f"{label}: error mentions {' or '.join(map(repr, phrases))}")
    dc.check(out.GetNumberOfCells() == 0 and out.GetNumberOfPoints() == 0, f"{label}: empty output")


wavelet = simple.Wavelet()
wavelet.WholeExtent = [-8, 8, -8, 8, -8, 8]
wavelet.UpdatePipeline()

# ---- Geometry.
flat = simple.Wavelet()
flat.WholeExtent = [-8, 8, -8, 8, 0, 0]
expect_error(simple.AdaptiveTetrahedra(Input=flat), "at least 2 points", "2-D image (1 point along z)")
line = simple.Wavelet()
line.WholeExtent = [-8, 8, 0, 0, 0, 0]
expect_error(simple.AdaptiveTetrahedra(Input=line), "at least 2 points", "1-D image")

# ---- Arrays.
cells_only = simple.PointDatatoCellData(Input=wavelet)
cells_only.PassPointData = 0
expect_error(simple.AdaptiveTetrahedra(Input=cells_only), "Cell Data to Point Data", "cell data only")

vector = simple.Calculator(Input=wavelet)
vector.ResultArrayName = "Vector"
vector.Function = "RTData*iHat + coordsY*jHat"
vec_filter = simple.AdaptiveTetrahedra(Input=vector)
vec_filter.Scalars = ["POINTS", "Vector"]
expect_error(vec_filter, "single-component", "3-component array")

missing = simple.AdaptiveTetrahedra(Input=wavelet)
missing.Scalars = ["POINTS", "NoSuchArray"]
expect_error(missing, "no point-data array named", "unknown array name")

nan = dc.programmable_image(simple, (9, 8, 7), "v = np.sin(x) + y\nv[100] = np.nan\nadd('f', v, scalars=True)\n")
expect_error(simple.AdaptiveTetrahedra(Input=nan), "non-finite", "a NaN sample")
inf = dc.programmable_image(simple, (9, 8, 7), "v = np.sin(x) + y\nv[5] = np.inf\nadd('f', v.astype(np.float32), scalars=True)\n")
expect_error(simple.AdaptiveTetrahedra(Input=inf), "non-finite", "an Inf sample (float32)")

bits = dc.programmable_image(
    simple,
    (9, 8, 7),
    "b = vtk.vtkBitArray()\nb.SetName('bits')\nb.SetNumberOfValues(x.size)\n"
    "for i in range(x.size):\n    b.SetValue(i, i % 2)\n"
    "out.GetPointData().SetScalars(b)\n",
)
expect_error(simple.AdaptiveTetrahedra(Input=bits), "does not read", "bit array (unsupported type)")

# 64-bit integers: converted to double with a warning when exact, refused beyond 2^53.
i64 = dc.programmable_image(simple, (9, 8, 7), "add('counts', (x * 7 + y * y - z).astype(np.int64), scalars=True)\n")
i64_filter = simple.AdaptiveTetrahedra(Input=i64, Tolerance=0.0)
with dc.ErrorCapture(i64_filter) as messages:
    i64_mesh = dc.fetch(i64_filter)
print(f"   [int64] {messages.text().strip()}")
dc.check("converted to double" in messages.text(), "int64 array: warns that it is converted to double")
dc.check_mesh(dc.fetch(i64), i64_mesh, "counts", 0.0, "int64 array converted, tol 0")
huge = dc.programmable_image(simple, (9, 8, 7), "add('big', (x * 7).astype(np.int64) + 2**60, scalars=True)\n")
expect_error(simple.AdaptiveTetrahedra(Input=huge), "2^53", "int64 beyond 2^53")

# ---- Parameters.
expect_error(simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=-1.0), "Tolerance must be", "negative Tolerance")
expect_error(simple.AdaptiveTetrahedra(Input=wavelet, MaximumNumberOfTetrahedra=-5), "MaximumNumberOfTetrahedra must be", "negative budget")
roi_filter = simple.AdaptiveTetrahedra(Input=wavelet, UseRegionOfInterest=1)
roi_filter.RegionOfInterest = [100.0, 110.0, 100.0, 110.0, 100.0, 110.0]
expect_error(roi_filter, "outside the image bounds", "region of interest outside the bounds")
roi_filter.RegionOfInterest = [5.0, -5.0, 0.0, 1.0, 0.0, 1.0]
expect_error(roi_filter, "min <= max", "inverted region of interest")

# ---- Too large: 20000^3 points (the hierarchy alone would need ~34 TB). The array is deliberately
# tiny: the size checks (the core's point-count limit, then available memory) come before anything
# reads or allocates.
big = simple.ProgrammableSource()
big.OutputDataSetType = "vtkImageData"
big.ScriptRequestInformation = (
    "executive = self.GetExecutive()\n"
    "executive.GetOutputInformation(0).Set(executive.WHOLE_EXTENT(), 0, 19999, 0, 19999, 0, 19999)\n"
)
big.Script = (
    "out = self.GetOutput()\nout.SetExtent(0, 19999, 0, 19999, 0, 19999)\n"
    "a = vtk.vtkFloatArray()\na.SetName('f')\na.SetNumberOfValues(8)\na.Fill(1.0)\n"
    "out.GetPointData().SetScalars(a)\n"
)
expect_error(simple.AdaptiveTetrahedra(Input=big), ("bytes are available", "points are supported"), "too large")

# ---- Abort: an observer of the progress sets AbortExecute during the build.
abort_filter = simple.AdaptiveTetrahedra(Input=wavelet)
vtk_filter = abort_filter.GetClientSideObject()
progress_seen = []


def abort_on_progress(obj, _event):
    progress_seen.append(obj.GetProgress())
    if obj.GetProgress() > 0.0:
        obj.SetAbortExecute(1)


tag = vtk_filter.AddObserver("ProgressEvent", abort_on_progress)
aborted = dc.fetch(abort_filter)
vtk_filter.RemoveObserver(tag)
vtk_filter.SetAbortExecute(0)
dc.check(len(progress_seen) > 0, f"progress reported during the build ({len(progress_seen)} events)")
dc.check(aborted.GetNumberOfCells() == 0, "AbortExecute during the build: empty output")
dc.check(dc.hierarchy_builds(abort_filter) == 0, "an aborted build is not counted or kept")
abort_filter.Tolerance = 2.0
after = dc.fetch(abort_filter)
dc.check(after.GetNumberOfCells() > 0 and dc.hierarchy_builds(abort_filter) == 1, "the next update builds normally")

# ---- Smooth data near the largest double: the error arithmetic would overflow (it passed as error
# 0, 6 tetrahedra); refused with a message instead.
near_max = dc.programmable_image(simple, (9, 8, 7), "add('f', 1.5e308 + x / 8 * 1e306, scalars=True)\n")
expect_error(simple.AdaptiveTetrahedra(Input=near_max, Tolerance=1e306), "overflow", "values near the largest double")

# ---- A direction matrix that differs from the identity by rounding is axis-aligned; a rotation
# is refused.
def with_direction(matrix):
    image = dc.programmable_image(
        simple, (9, 8, 7), f"add('f', np.sin(x) + y * z, scalars=True)\nout.SetDirectionMatrix({', '.join(map(repr, matrix))})\n"
    )
    return simple.AdaptiveTetrahedra(Input=image, Tolerance=0.5)


almost = with_direction((1.0, 1e-12, 0.0, -1e-12, 1.0, 0.0, 0.0, 0.0, 1.0 - 1e-12))
with dc.ErrorCapture(almost) as messages:
    almost_mesh = dc.fetch(almost)
dc.check(messages.text() == "" and almost_mesh.GetNumberOfCells() > 0, f"direction 1e-12 from the identity: meshed ({messages.text()!r})")
expect_error(with_direction((0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)), "oriented", "a rotated image")

# ---- Isosurface warnings, text from the core: isovalue outside the data range, triangle budget below
# the coarsest surface (six root tetrahedra).
for isovalues, budget, phrase in (([1e9], 0, "outside"), ([150.0], 1, "budget of 1 triangles cannot be met")):
    iso = simple.AdaptiveIsosurface(Input=wavelet, Isosurfaces=isovalues, MaximumNumberOfTriangles=budget)
    with dc.ErrorCapture(iso) as messages:
        surface = dc.fetch(iso)
    print(f"   [isosurface warning] {messages.text().strip()}")
    dc.check(phrase in messages.text(), f"isosurface {isovalues}, budget {budget}: warns {phrase!r}")

# ---- A tetrahedron budget below the coarsest mesh, text from the core: a 32^3 image (2^k points, not
# 2^k + 1) has a band of small tetrahedra along its far faces that no budget removes. That mesh is the
# output, with a warning: at every execution of Adaptive Tetrahedra; once per budget and hierarchy for
# View Dependent Tetrahedra (the Adaptive Volume representation executes it at every camera move).
band = simple.Wavelet()
band.WholeExtent = [0, 31, 0, 31, 0, 31]
band.UpdatePipeline()
coarsest = dc.fetch(simple.AdaptiveTetrahedra(Input=band, Tolerance=1e30)).GetNumberOfCells()
phrase = "budget of 100 tetrahedra cannot be met: the coarsest mesh of this 32×32×32 image has"
budgeted = simple.AdaptiveTetrahedra(Input=band, Tolerance=0.0, MaximumNumberOfTetrahedra=100)
with dc.ErrorCapture(budgeted) as messages:
    cells = dc.fetch(budgeted).GetNumberOfCells()
print(f"   [budget warning] {messages.text().strip()}")
dc.check(phrase in messages.text() and f"has {coarsest} tetrahedra" in messages.text() and cells == coarsest,
         f"Adaptive Tetrahedra, budget 100 below the coarsest mesh ({coarsest}): that mesh, a warning")
budgeted.MaximumNumberOfTetrahedra = coarsest
with dc.ErrorCapture(budgeted) as messages:
    cells = dc.fetch(budgeted).GetNumberOfCells()
dc.check(messages.text() == "" and cells == coarsest, f"budget equal to the coarsest mesh: no warning ({messages.text()!r})")
view = simple.ViewDependentTetrahedra(Input=band, MaximumNumberOfTetrahedra=100)
said = []
for position, budget in (((0.0, 0.0, 100.0), 100), ((100.0, 0.0, 0.0), 100), ((100.0, 0.0, 0.0), 200)):
    view.CameraPosition = position
    view.MaximumNumberOfTetrahedra = budget
    with dc.ErrorCapture(view) as messages:
        cells = dc.fetch(view).GetNumberOfCells()
    said.append(f"budget of {budget} tetrahedra cannot be met" in messages.text() and cells == coarsest)
dc.check(said == [True, False, True], f"View Dependent Tetrahedra: warns for a budget below the coarsest mesh once per budget, not per camera ({said})")

# ---- An allocation failure is the filter's error, not the end of the process: a 300^3 Wavelet with
# the process's address space limited to what it uses plus 32 MiB (the hierarchy alone needs 54 MB,
# 2 bytes per point).
import resource  # noqa: E402

dc.fetch(simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=4.0))  # threads started before the limit
large = simple.Wavelet()
large.WholeExtent = [0, 299, 0, 299, 0, 299]
large.UpdatePipeline()
limited = simple.AdaptiveTetrahedra(Input=large, Tolerance=50.0)
with open("/proc/self/status") as status:
    used = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmSize:"))
soft, hard = resource.getrlimit(resource.RLIMIT_AS)
resource.setrlimit(resource.RLIMIT_AS, (used + 32 * 2**20, hard))
try:
    expect_error(limited, "not enough memory", "300^3 under a memory limit")
    small = dc.fetch(simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=4.0))
    dc.check(small.GetNumberOfCells() > 0, "under the same limit, a small image is still meshed")
finally:
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))

# ---- After all of this the filter still works on good data.
ok_mesh = dc.fetch(simple.AdaptiveTetrahedra(Input=wavelet, Tolerance=4.0))
dc.check_mesh(dc.fetch(wavelet), ok_mesh, "RTData", 4.0, "good input after the bad ones")

dc.finish("test_bad_inputs")
