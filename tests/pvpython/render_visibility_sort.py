"""vtkDiamondsVisibilitySort (issue 14): the exact order of View Dependent Tetrahedra's cells for
vtkProjectedTetrahedraMapper, rebuilt from the cell data BisectionPath. Renders: run under
`xvfb-run -a pvpython tests/pvpython/render_visibility_sort.py` (scripts/test-integration.sh does).

Checks, each independent of the bisection tree (order_violations in diamonds_checks.py: for every
face shared by two tetrahedra, the one across the face's plane from the eye comes first):
- the order the sort yields for cameras other than the filter's (outside, inside the volume), back
  to front and front to back, through a model transform (the eye taken into the data's coordinates);
- the same after the cells were shuffled with their cell data (as a redistribution does) and on a
  subset of them (Threshold): the order follows the cell array, not the cell ids;
- vtkCellCenterDepthSort's order on the same mesh and cameras is reported for comparison;
- vtkProjectedTetrahedraMapper renders the mesh with the sort (it was asked for the order, the tree
  built once, the image not empty) and the picture equals one rendered from the cells written in
  exact order by the filter (SortCells) with the mapper's sort fed that order;
- orders given by the filter: with SortCells 1 / 2 the output object is marked, and a sort asked for
  that eye returns the cells' own order (or its reverse) without building a tree, equal to the order
  rebuilt from the paths of an unmarked copy and exact face by face; another eye, or paths modified
  since, are ordered from the paths; SortCells 0 leaves no mark;
- an input without BisectionPath is a clear error and yields no cells.
"""

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkCommand, vtkIdList
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction, vtkUnstructuredGrid
from vtkmodules.vtkRenderingCore import (
    vtkCamera,
    vtkCellCenterDepthSort,
    vtkColorTransferFunction,
    vtkRenderer,
    vtkRenderWindow,
    vtkVolume,
    vtkVolumeProperty,
    vtkWindowToImageFilter,
)
from vtkmodules.vtkRenderingVolume import vtkProjectedTetrahedraMapper
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401 (OpenGL overrides)
import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401

from diamonds_checks import check, fetch, finish, mesh_arrays, order_violations, require_plugin

simple = require_plugin()
from paraview import servermanager  # noqa: E402

wavelet = simple.Wavelet(WholeExtent=[0, 32, 0, 32, 0, 32])
f = simple.ViewDependentTetrahedra(Input=wavelet, Scalars=["POINTS", "RTData"], CameraPosition=[70.0, 30.0, 40.0],
                                   CameraFocalPoint=[16.0, 16.0, 16.0], CameraViewUp=[0.0, 0.0, 1.0],
                                   PixelTolerance=3.0, MaximumNumberOfTetrahedra=0, SortCells=0)
ug = fetch(f)
points, tets, _ = mesh_arrays(ug)



def new_sort():
    """A vtkDiamondsVisibilitySort (its proxy, and its object)."""
    proxy = servermanager.misc.DiamondsVisibilitySort()
    return proxy, proxy.GetClientSideObject()


def info(proxy, name):
    proxy.UpdatePropertyInformation()
    return proxy.GetProperty(name).GetElement(0)


sort_proxy, sort = new_sort()
check(sort.IsA("vtkVisibilitySort"), f"the DiamondsVisibilitySort proxy makes a vtkVisibilitySort ({sort.GetClassName()})")


def order_of(sorter, data, position, back_to_front=True, transform=None, chunk=1000):
    camera = vtkCamera()
    camera.SetPosition(*position)
    camera.SetFocalPoint(16.0, 16.0, 16.0)
    sorter.SetInput(data)
    sorter.SetCamera(camera)
    sorter.SetModelTransform(transform if transform is not None else vtkMatrix4x4())  # None crashes VTK
    if back_to_front:
        sorter.SetDirectionToBackToFront()
    else:
        sorter.SetDirectionToFrontToBack()
    sorter.SetMaxCellsReturned(chunk)
    sorter.InitTraversal()
    parts = []
    while True:
        cells = sorter.GetNextCells()
        if cells is None:
            break
        parts.append(vtk_to_numpy(cells).copy())
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


def check_sorted(label, data, order, eye, back_to_front=True):
    pts, tt, _ = mesh_arrays(data)
    is_permutation = len(order) == len(tt) and (np.sort(order) == np.arange(len(tt))).all()
    check(is_permutation, f"{label}: the sort returns every cell once ({len(order)} of {len(tt)})")
    if not is_permutation:
        return
    seq = tt[order] if back_to_front else tt[order[::-1]]
    bad, checked, on_plane = order_violations(pts, seq, eye)
    check(bad == 0 and checked > 0, f"{label}: {checked} interior faces in order ({bad} violations, {on_plane} on the eye's plane)")


eyes = {"outside": (-40.0, 50.0, 25.0), "inside": (20.3, 11.7, 9.2), "on lattice planes": (16.0, 48.0, 16.0)}
for name, eye in eyes.items():
    check_sorted(f"eye {name}, back to front", ug, order_of(sort, ug, eye), eye)
    check_sorted(f"eye {name}, front to back", ug, order_of(sort, ug, eye, back_to_front=False), eye, back_to_front=False)
    centers = order_of(vtkCellCenterDepthSort(), ug, eye)
    bad, checked, _ = order_violations(points, tets[centers], eye)
    print(f"   vtkCellCenterDepthSort, eye {name}: {bad} of {checked} interior faces out of order ({100.0 * bad / max(checked, 1):.1f} %)")
check(info(sort_proxy, 'NumberOfTreeBuilds') == 1, f"one tree for the mesh whatever the camera ({info(sort_proxy, 'NumberOfTreeBuilds')})")

# A model transform: the data rotated and moved; the eye is taken back into the data's coordinates.
m = vtkMatrix4x4()
c, s = np.cos(0.7), np.sin(0.7)
for i, row in enumerate([[c, -s, 0.0, 5.0], [s, c, 0.0, -3.0], [0.0, 0.0, 1.0, 2.0], [0.0, 0.0, 0.0, 1.0]]):
    for j, v in enumerate(row):
        m.SetElement(i, j, v)
eye = np.array([60.0, -20.0, 30.0])
inverse = vtkMatrix4x4()
vtkMatrix4x4.Invert(m, inverse)
eye_in_data = np.array(inverse.MultiplyPoint([*eye, 1.0])[:3])
check_sorted("model transform", ug, order_of(sort, ug, eye, transform=m), eye_in_data)


def with_cells(data, keep):
    """A copy of `data` with only the cells `keep`, in that order, and their cell data."""
    out = vtkUnstructuredGrid()
    out.SetPoints(data.GetPoints())
    out.GetPointData().ShallowCopy(data.GetPointData())
    out.GetFieldData().ShallowCopy(data.GetFieldData())
    ids = vtkIdList()
    ids.SetNumberOfIds(len(keep))
    for k, i in enumerate(keep):
        ids.SetId(k, int(i))
    out.Allocate(len(keep))
    for i in keep:
        cell_ids = vtkIdList()
        data.GetCellPoints(int(i), cell_ids)
        out.InsertNextCell(10, cell_ids)
    out.GetCellData().CopyAllocate(data.GetCellData(), len(keep))
    out.GetCellData().CopyData(data.GetCellData(), ids, _range(len(keep)))
    return out


def _range(n):
    ids = vtkIdList()
    ids.SetNumberOfIds(n)
    for k in range(n):
        ids.SetId(k, k)
    return ids


rng = np.random.default_rng(14)
shuffled = with_cells(ug, rng.permutation(ug.GetNumberOfCells()))
check_sorted("cells shuffled", shuffled, order_of(sort, shuffled, eyes["outside"]), eyes["outside"])
check(info(sort_proxy, 'NumberOfTreeBuilds') == 2, "a new input: the tree rebuilt from its paths")
subset = with_cells(ug, np.flatnonzero(rng.random(ug.GetNumberOfCells()) < 0.5)[::-1])
check_sorted("a random half of the cells, reversed", subset, order_of(sort, subset, eyes["inside"]), eyes["inside"])

# Rendering with vtkProjectedTetrahedraMapper.
color = vtkColorTransferFunction()
color.AddRGBPoint(40.0, 0.2, 0.2, 0.9)
color.AddRGBPoint(160.0, 0.9, 0.9, 0.2)
color.AddRGBPoint(280.0, 0.9, 0.1, 0.1)
opacity = vtkPiecewiseFunction()
opacity.AddPoint(40.0, 0.0)
opacity.AddPoint(280.0, 0.6)
prop = vtkVolumeProperty()
prop.SetColor(color)
prop.SetScalarOpacity(opacity)
prop.SetScalarOpacityUnitDistance(2.0)


def render(data, sorter):
    mapper = vtkProjectedTetrahedraMapper()
    mapper.SetVisibilitySort(sorter)
    mapper.SetInputData(data)
    data.GetPointData().SetActiveScalars("RTData")
    volume = vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    renderer = vtkRenderer()
    renderer.SetBackground(0.0, 0.0, 0.0)
    renderer.AddVolume(volume)
    camera = renderer.GetActiveCamera()
    camera.SetPosition(*eyes["outside"])
    camera.SetFocalPoint(16.0, 16.0, 16.0)
    camera.SetViewUp(0.0, 0.0, 1.0)
    renderer.ResetCameraClippingRange()
    window = vtkRenderWindow()
    window.SetSize(300, 300)
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    window.Render()
    grab = vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.ReadFrontBufferOff()
    grab.Update()
    image = grab.GetOutput()
    return vtk_to_numpy(image.GetPointData().GetScalars()).astype(np.float64)


renders_proxy, renders = new_sort()
picture = render(ug, renders)
check(info(renders_proxy, 'LastOrderSeconds') > 0.0 and info(renders_proxy, 'NumberOfTreeBuilds') == 1,
      f"the mapper asked the sort for the order ({info(renders_proxy, 'LastOrderSeconds') * 1e3:.2f} ms)")
lit = (picture.max(axis=1) > 10).mean()
check(lit > 0.05, f"the rendering is not empty ({100 * lit:.0f} % of the pixels lit)")


# The reference: the cells written back to front by the filter itself (SortCells 1 from the render
# camera), rendered the same way.
f.CameraPosition = list(eyes["outside"])
f.SortCells = 1
in_order = fetch(f)
reference = render(in_order, new_sort()[1])
f.SortCells = 0
same_mesh = in_order.GetNumberOfCells() > 0
check(same_mesh, "the filter's own order from the render camera")
diff = np.abs(render(fetch(f), new_sort()[1]) - reference).max()
check(diff <= 1.0, f"the same picture whether the cells came in order or the sort ordered them (max difference {diff:.0f})")
approximate = render(fetch(f), vtkCellCenterDepthSort())
print(f"   vtkCellCenterDepthSort's picture differs from the exact one by up to {np.abs(approximate - reference).max():.0f} "
      f"(RMSE {np.sqrt(((approximate - reference) ** 2).mean()):.2f}) of 255")

# Orders given by the filter (the Adaptive Volume representation's path): with SortCells the cells
# are written in exact order from CameraPosition and the output object is marked, so a sort asked for
# that very eye hands them out as they are, without a tree; the order from their paths (a copy, which
# carries no mark) is the same, and face by face exact. Eyes outside, inside, on lattice planes.
given_proxy, given = new_sort()
for name, eye in eyes.items():
    f.CameraPosition = list(eye)
    for sort_cells, back_to_front in ((1, True), (2, False)):
        f.SortCells = sort_cells
        f.UpdatePipeline()
        out = f.GetClientSideObject().GetOutputDataObject(0)
        n = out.GetNumberOfCells()
        label = f"SortCells {sort_cells}, eye {name}"
        builds, gifts = info(given_proxy, 'NumberOfTreeBuilds'), info(given_proxy, 'NumberOfGivenOrders')
        for same_direction in (True, False):
            bf = back_to_front == same_direction
            order = order_of(given, out, eye, back_to_front=bf, chunk=n + 1)
            expected = np.arange(n) if same_direction else np.arange(n)[::-1]
            check(len(order) == n and (order == expected).all(),
                  f"{label}: the cells' own order handed out {'as it is' if same_direction else 'reversed'} ({n} cells)")
            check_sorted(f"{label}, given order {'back to front' if bf else 'front to back'}", out, order, eye, bf)
        check(info(given_proxy, 'NumberOfGivenOrders') == gifts + 2 and info(given_proxy, 'NumberOfTreeBuilds') == builds,
              f"{label}: no tree built for the eye the cells were written for")
        copy = vtkUnstructuredGrid()
        copy.ShallowCopy(out)
        from_paths = order_of(given, copy, eye, back_to_front=back_to_front, chunk=n + 1)
        check((from_paths == np.arange(n)).all() and info(given_proxy, 'NumberOfTreeBuilds') == builds + 1,
              f"{label}: a copy (no mark) is ordered from its paths, in the same order")
f.CameraPosition = list(eyes["outside"])
f.SortCells = 1
f.UpdatePipeline()
out = f.GetClientSideObject().GetOutputDataObject(0)
gifts = info(given_proxy, 'NumberOfGivenOrders')
other = (-10.0, -35.0, 60.0)
check_sorted("SortCells 1, another eye: ordered from the paths", out, order_of(given, out, other), other)
out.GetCellData().GetArray("BisectionPath").Modified()  # as if the paths were rewritten in place
check_sorted("SortCells 1, paths modified since: ordered from the paths", out,
             order_of(given, out, eyes["outside"]), eyes["outside"])
check(info(given_proxy, 'NumberOfGivenOrders') == gifts, "another eye or modified paths: the mark is not taken")
f.SortCells = 0
f.UpdatePipeline()
out = f.GetClientSideObject().GetOutputDataObject(0)
check_sorted("SortCells 0, the filter's eye: ordered from the paths", out,
             order_of(given, out, eyes["outside"]), eyes["outside"])
check(info(given_proxy, 'NumberOfGivenOrders') == gifts, "SortCells 0: the output carries no order for the sort to take")

# Bad input: no BisectionPath.
tetra = fetch(simple.Tetrahedralize(Input=wavelet))
messages = []
bad_sort = new_sort()[1]
bad_sort.AddObserver(vtkCommand.ErrorEvent, lambda *_: messages.append("error"))
order = order_of(bad_sort, tetra, eyes["outside"])
check(len(order) == 0 and messages, f"an input without BisectionPath: an error, no cells ({len(order)} cells, {len(messages)} errors)")

finish("render_visibility_sort")
