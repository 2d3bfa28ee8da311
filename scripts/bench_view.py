"""Benchmark of view-dependent refinement and exact-order volume rendering (issue 14): bonsai 256³,
a 60-frame orbit at tetrahedron budgets 100 K, 400 K and 1 M.

    python3 scripts/bench_view.py     # runs each budget in its own `xvfb-run -a pvbatch`, replaces
                                      # its section of docs/benchmarks.md, writes the PNG strip

The bonsai is padded with one layer of zeros at its far faces to 257³ (see `padded_bonsai`: at 256
points per axis the coarsest conforming mesh already has 903,864 tetrahedra). Per frame (View
Dependent Tetrahedra, the camera orbiting the volume by 6° per frame about the vertical axis through
its centre, 30° view angle, 400×300 pixels, Pixel Tolerance 0.5 so that the budget binds): the
refinement's own time (the filter's FrameSeconds: re-evaluating the queued diamonds, splits and
merges), its splits and merges, the filter's whole update (refinement and the VTK output with each
cell's bisection path), and the exact sort as the Adaptive Volume representation runs it: the filter
with SortCells 1 (its setting there) writes the mesh back to front from the camera (the core walks
the bisection forest far child first while writing), and vtkDiamondsVisibilitySort, given that
output for that eye, hands the cells out as they are. What ordering costs in the write: every
frame the filter runs again on the same camera with SortCells 0 and 2 (alternating which first; 2,
front to back, is the same walk), its write time (update minus FrameSeconds) each way. Beside it, the exact sort of any mesh
(vtkDiamondsVisibilitySort on a copy, which carries no order: the BSP tree rebuilt from the cells'
paths, then one traversal from the eye). Every 4th frame vtkCellCenterDepthSort (the default of
vtkProjectedTetrahedraMapper) sorts the same mesh, alternating which sort goes first. Every 15th
frame the tetrahedra are rendered by vtkProjectedTetrahedraMapper in exact order (Mesa software
rendering under xvfb: seconds per frame, hence not every frame) and compared with the
full-resolution volume rendering of the image (vtkSmartVolumeMapper, the mapper of ParaView's Volume
representation, same transfer functions and camera): RMSE of the 8-bit RGB images. Frame 0 (refined
from the coarsest mesh) is left out of the medians. Not a test: it measures.
"""

import json
import os
import statistics
import subprocess
import sys
import time

from benchlib import replace_section  # scripts/benchlib.py, beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BONSAI = os.path.join(ROOT, "..", "shared", "data", "volumes", "bonsai_256x256x256_uint8_lossy.vti")
IMAGES = os.path.join(ROOT, "docs", "images")
STRIP = os.path.join(IMAGES, "view-dependent-bonsai.png")
HEADING = "## View-dependent refinement and exact-order volume rendering (issue 14)"
BUDGETS = [100_000, 400_000, 1_000_000]
FRAMES = int(os.environ.get("BENCH_VIEW_FRAMES", "60"))  # fewer for a quick try of the script
DEGREES = 6.0
SIZE = (400, 300)
PIXEL_TOLERANCE = 0.5
COMPARE_EVERY = 15
CENTER_SORT_EVERY = 4
PADDED = os.path.join(ROOT, "build", "bonsai_padded_257.vti")
# The previous run (commit 21f0901, load 9.6), when the representation's sort rebuilt the tree from
# the paths every frame (kept for comparison).
BEFORE = ("Before (commit 21f0901, the representation's exact sort rebuilt the BSP tree from the cells' paths "
          "every frame; load 9.6): refinement 20.7 / 81.5 / 196.3 ms, exact sort 31.1 (15.7 + 15.0) / 96.9 "
          "(39.0 + 59.3) / 215.8 (94.1 + 117.8) ms at 100 K / 400 K / 1 M; refinement + exact sort at 400 K "
          "178.4 ms; vtkCellCenterDepthSort on the same meshes 266 / 1242 / 2992 ms (a yardstick of the machine's "
          "load in each run).")


def padded_bonsai():
    """The bonsai with one layer of zeros (air, like its borders) added at its far faces: 257³ =
    2^8 + 1 points per axis, whose coarsest mesh is the 6 root tetrahedra. At 256 points per axis the
    far faces cut through the lattice and the coarsest conforming mesh already has 903,864
    tetrahedra (the band of small tetrahedra along them), above two of the three budgets. Every
    sample of the bonsai is kept unchanged."""
    if os.path.exists(PADDED):
        return PADDED
    from vtkmodules.vtkImagingCore import vtkImageConstantPad
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter

    reader = vtkXMLImageDataReader()
    reader.SetFileName(BONSAI)
    pad = vtkImageConstantPad()
    pad.SetInputConnection(reader.GetOutputPort())
    pad.SetOutputWholeExtent(0, 256, 0, 256, 0, 256)
    pad.SetConstant(0)
    writer = vtkXMLImageDataWriter()
    writer.SetInputConnection(pad.GetOutputPort())
    writer.SetFileName(PADDED + ".part")
    writer.Write()
    os.replace(PADDED + ".part", PADDED)
    return PADDED


def transfer_functions():
    """Colour and opacity of the bonsai (u8): air transparent, leaves green, trunk brown."""
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction, vtkVolumeProperty
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction

    color = vtkColorTransferFunction()
    color.AddRGBPoint(0, 0.0, 0.0, 0.0)
    color.AddRGBPoint(40, 0.1, 0.6, 0.1)
    color.AddRGBPoint(120, 0.5, 0.35, 0.15)
    color.AddRGBPoint(255, 1.0, 0.9, 0.8)
    opacity = vtkPiecewiseFunction()
    opacity.AddPoint(0, 0.0)
    opacity.AddPoint(35, 0.0)
    opacity.AddPoint(60, 0.05)
    opacity.AddPoint(255, 0.3)
    prop = vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(4.0)
    prop.SetInterpolationTypeToLinear()
    return prop


def grab(window):
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter

    w2i = vtkWindowToImageFilter()
    w2i.SetInput(window)
    w2i.SetInputBufferTypeToRGB()
    w2i.ReadFrontBufferOff()
    w2i.Update()
    img = w2i.GetOutput()
    w, h, _ = img.GetDimensions()
    return vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, 3).astype(np.float64)


def measure(budget):
    """One budget, in pvbatch: prints one JSON line; saves frame 0 (and the reference) as .npy."""
    import numpy as np
    from paraview import servermanager
    from paraview.simple import ViewDependentTetrahedra, XMLImageDataReader
    from vtkmodules.vtkRenderingCore import vtkCamera, vtkRenderer, vtkRenderWindow, vtkVolume
    from vtkmodules.vtkRenderingVolume import vtkProjectedTetrahedraMapper
    from vtkmodules.vtkRenderingVolumeOpenGL2 import vtkSmartVolumeMapper  # noqa: F401 (OpenGL overrides)
    from vtkmodules.vtkRenderingCore import vtkCellCenterDepthSort
    from vtkmodules.vtkCommonDataModel import vtkUnstructuredGrid
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401

    reader = XMLImageDataReader(FileName=[padded_bonsai()])
    reader.UpdatePipeline()
    image = reader.GetClientSideObject().GetOutputDataObject(0)
    center = np.array(image.GetCenter())
    radius = 2.2 * image.GetLength()
    filt = ViewDependentTetrahedra(Input=reader, ViewportSize=list(SIZE), PixelTolerance=PIXEL_TOLERANCE,
                                   MaximumNumberOfTetrahedra=budget, SortCells=1, ViewAngle=30.0,
                                   CameraFocalPoint=list(center), CameraViewUp=[0.0, 0.0, 1.0])
    sort_proxy = servermanager.misc.DiamondsVisibilitySort()
    exact = sort_proxy.GetClientSideObject()
    paths_proxy = servermanager.misc.DiamondsVisibilitySort()
    from_paths = paths_proxy.GetClientSideObject()

    def sort_info(name, proxy=sort_proxy):
        proxy.UpdatePropertyInformation()
        return proxy.GetProperty(name).GetElement(0)

    centers = vtkCellCenterDepthSort()

    prop = transfer_functions()
    mapper = vtkProjectedTetrahedraMapper()
    ordering = servermanager.misc.DiamondsVisibilitySort().GetClientSideObject()
    mapper.SetVisibilitySort(ordering)

    def offscreen(volume_mapper):
        """A white off-screen window of SIZE showing `volume_mapper` with the transfer functions."""
        volume = vtkVolume()
        volume.SetMapper(volume_mapper)
        volume.SetProperty(prop)
        renderer = vtkRenderer()
        renderer.SetBackground(1.0, 1.0, 1.0)
        renderer.AddVolume(volume)
        window = vtkRenderWindow()
        window.SetSize(*SIZE)
        window.SetOffScreenRendering(1)
        window.AddRenderer(renderer)
        return renderer, window

    renderer, window = offscreen(mapper)
    camera = renderer.GetActiveCamera()
    camera.SetViewAngle(30.0)
    camera.SetFocalPoint(*center)
    camera.SetViewUp(0.0, 0.0, 1.0)

    reference_mapper = vtkSmartVolumeMapper()
    reference_mapper.SetInputData(image)
    ref_renderer, ref_window = offscreen(reference_mapper)
    ref_renderer.SetActiveCamera(camera)

    def drain(sort, mesh):
        sort.SetInput(mesh)
        sort.SetCamera(camera)
        sort.SetDirectionToBackToFront()
        sort.SetMaxCellsReturned(1 << 20)
        t = time.perf_counter()
        sort.InitTraversal()
        cells = 0
        while True:
            chunk = sort.GetNextCells()
            if chunk is None:
                break
            cells += chunk.GetNumberOfTuples()
        return time.perf_counter() - t, cells

    frames = []
    for frame in range(FRAMES):
        a = np.radians(DEGREES * frame)
        position = center + radius * np.array([np.cos(a), np.sin(a), 0.35])
        camera.SetPosition(*position)
        filt.CameraPosition = list(position)
        t = time.perf_counter()
        filt.UpdatePipeline()
        update = time.perf_counter() - t
        mesh = filt.GetClientSideObject().GetOutputDataObject(0)
        # Read now: the executions below on the same camera rewrite the output's field data.
        fd = mesh.GetFieldData()
        value = {name: fd.GetArray(name).GetTuple1(0)
                 for name in ("FrameSeconds", "FrameSplits", "FrameMerges", "PixelToleranceReached")}
        n = mesh.GetNumberOfCells()
        if frame % CENTER_SORT_EVERY != 0:
            exact_s, exact_n = drain(exact, mesh)
            centers_s, centers_n = None, n
        elif frame % (2 * CENTER_SORT_EVERY) == 0:
            exact_s, exact_n = drain(exact, mesh)
            centers_s, centers_n = drain(centers, mesh)
        else:
            centers_s, centers_n = drain(centers, mesh)
            exact_s, exact_n = drain(exact, mesh)
        assert exact_n == n and centers_n == n, (exact_n, centers_n, n)
        given = sort_info("NumberOfGivenOrders")
        assert given == frame + 1, f"frame {frame}: the sort did not take the filter's order ({given})"
        copy = vtkUnstructuredGrid()
        copy.ShallowCopy(mesh)  # no order mark: the tree is rebuilt from the paths
        paths_s, paths_n = drain(from_paths, copy)
        assert paths_n == n, (paths_n, n)
        # The write with and without the order, on the same camera (the refinement has nothing to do),
        # alternating which goes first; the representation's setting (SortCells 1) is left on.
        # In order is timed with SortCells 2 (front to back: the same walk, the other child first), so that
        # every setting is a change and runs the filter; then SortCells 1 again.
        write = {}
        for sort_cells in ((0, 2, 1) if frame % 2 == 0 else (2, 0, 1)):
            filt.SortCells = sort_cells
            t = time.perf_counter()
            filt.UpdatePipeline()
            elapsed = time.perf_counter() - t
            again = filt.GetClientSideObject().GetOutputDataObject(0).GetFieldData()
            write[sort_cells] = elapsed - again.GetArray("FrameSeconds").GetTuple1(0)
        mesh = filt.GetClientSideObject().GetOutputDataObject(0)
        render = None
        if frame % COMPARE_EVERY == 0:
            mapper.SetInputData(mesh)
            mesh.GetPointData().SetActiveScalars("density")
            t = time.perf_counter()
            window.Render()
            render = time.perf_counter() - t
        record = {
            "frame": frame, "tets": n, "refine": value["FrameSeconds"], "splits": value["FrameSplits"],
            "merges": value["FrameMerges"], "tolerance": value["PixelToleranceReached"], "update": update,
            "exact_sort": exact_s, "paths_sort": paths_s, "paths_build": sort_info("LastBuildSeconds", paths_proxy),
            "paths_order": sort_info("LastOrderSeconds", paths_proxy), "center_sort": centers_s, "render": render,
            "write_plain": write[0], "write_ordered": write[2],
        }
        if frame % COMPARE_EVERY == 0:
            ours = grab(window)
            ref_window.Render()
            ref = grab(ref_window)
            record["rmse"] = float(np.sqrt(((ours - ref) ** 2).mean()))
            if frame == 0:
                np.save(os.path.join(ROOT, "build", f"bench_view_{budget}.npy"), ours)
                np.save(os.path.join(ROOT, "build", "bench_view_reference.npy"), ref)
        frames.append(record)
        print(json.dumps(record), file=sys.stderr, flush=True)
    print("RESULT " + json.dumps(frames), flush=True)


def run(budget):
    env = dict(os.environ, PV_PLUGIN_PATH=os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds"))
    out = subprocess.run(
        ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24", "pvbatch", __file__, "--measure", str(budget)],
        env=env, check=True, stdout=subprocess.PIPE, text=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def median(frames, key, scale=1.0, first=1):
    """Median of `key` over the frames from `first` that measured it."""
    return statistics.median(f[key] for f in frames[first:] if f[key] is not None) * scale


def report(results):
    load = os.getloadavg()[0]
    lines = [HEADING, "",
             f"Bonsai 256³ (u8) padded with zeros to 257³ (at 256³ the coarsest conforming mesh has 903,864 "
             f"tetrahedra: the band along the far faces), View Dependent Tetrahedra at Pixel Tolerance {PIXEL_TOLERANCE:g} on a "
             f"{SIZE[0]}×{SIZE[1]} viewport (30° view angle), a {FRAMES}-frame orbit ({DEGREES:g}° per frame, "
             "camera 2.2 diagonals from the centre, 20° above the equator), carried frame to frame by the split "
             "and merge queues; `scripts/bench_view.py`, each budget its own `xvfb-run -a pvbatch`, software "
             f"rendering (Mesa), 2 cores shared with other builds (load {load:.1f} when written). Medians over "
             "frames 1-59 (frame 0 refines from the coarsest mesh: its time is given apart). The exact sort as the "
             "Adaptive Volume representation runs it: the filter with SortCells 1 (the representation's setting) "
             "writes the mesh back to front from the camera (the core walks the bisection forest far child first "
             "while writing: no tree), and vtkDiamondsVisibilitySort, given that output for that eye, hands the "
             "cells out as they are (column *given*); what the order costs the write is measured every frame by "
             "running the filter again on the same camera with SortCells 0 and 2 (alternating which first; 2 is the "
             "same walk front to back; write = update minus FrameSeconds; the difference is within the noise of a loaded machine: the core probe "
             "`cargo run --release -p diamonds-core --example probe -- bonsai257.u8 257 257 257 view 400000 60` "
             "times the core's write alone, unordered and in order). *From paths*: vtkDiamondsVisibilitySort on a copy of the mesh (no order "
             "given: BSP tree rebuilt from the cells' bisection paths, then one traversal), the exact sort of any "
             "mesh. vtkCellCenterDepthSort, the default sort of vtkProjectedTetrahedraMapper, runs on the same mesh "
             "and camera every 4th frame, alternating with the exact sort; the sorts include their per-mesh "
             "preparation, since the mesh changes every frame. Render: vtkProjectedTetrahedraMapper with the "
             "exact sort, every 15th frame (median of frames 15, 30, 45); frame = filter update + exact sort (given) "
             "+ render. RMSE: 8-bit RGB against vtkSmartVolumeMapper on the full image (the mapper of ParaView's "
             f"Volume representation; same transfer functions and camera), mean over frames 0, 15, 30, 45; it hardly "
             "changes with the budget: what remains is mostly the difference between cell projection of linear "
             "tetrahedra and ray casting, not the mesh.", "",
             "| budget | tetrahedra | frame 0 refinement ms | refinement ms | max refinement ms | splits / merges "
             "per frame | filter update ms | write ms unordered / in order | exact sort ms, given | exact sort ms "
             "from paths (tree + order) | vtkCellCenterDepthSort ms | speed-up (from paths) | render ms | frame ms "
             "| RMSE |",
             "|---:|---:|---:|---:|---:|---|---:|---|---:|---|---:|---:|---:|---:|---:|"]
    for budget, frames in results:
        rest = frames[1:]
        rmse = [f["rmse"] for f in frames if "rmse" in f]
        frame_ms = statistics.median(f["update"] + f["exact_sort"] for f in rest) * 1e3 + median(frames, "render", 1e3)
        lines.append(
            f"| {budget:,} | {int(median(frames, 'tets')):,} | {frames[0]['refine'] * 1e3:.0f} | "
            f"{median(frames, 'refine', 1e3):.1f} | {max(f['refine'] for f in rest) * 1e3:.1f} | "
            f"{statistics.mean(f['splits'] for f in rest):,.0f} / {statistics.mean(f['merges'] for f in rest):,.0f} | "
            f"{median(frames, 'update', 1e3):.0f} | {median(frames, 'write_plain', 1e3):.1f} / "
            f"{median(frames, 'write_ordered', 1e3):.1f} | {median(frames, 'exact_sort', 1e3):.2f} | "
            f"{median(frames, 'paths_sort', 1e3):.1f} "
            f"({median(frames, 'paths_build', 1e3):.1f} + {median(frames, 'paths_order', 1e3):.1f}) | "
            f"{median(frames, 'center_sort', 1e3):.1f} | "
            f"{median(frames, 'center_sort') / median(frames, 'paths_sort'):.1f}× | "
            f"{median(frames, 'render', 1e3):.0f} | {frame_ms:.0f} | {statistics.mean(rmse):.2f} |")
    by = dict(results)
    if 400_000 in by and 1_000_000 in by:
        f4 = by[400_000]
        ordering = median(f4, "write_ordered", 1e3) - median(f4, "write_plain", 1e3)
        refine_sort = median(f4, "refine", 1e3) + max(ordering, 0.0) + median(f4, "exact_sort", 1e3)
        from_paths = median(f4, "refine", 1e3) + median(f4, "paths_sort", 1e3)
        rmse4 = statistics.mean(f["rmse"] for f in f4 if "rmse" in f)
        rmse1 = statistics.mean(f["rmse"] for f in by[1_000_000] if "rmse" in f)
        ratio = median(f4, "center_sort") / median(f4, "paths_sort")
        lines += ["", "Goals at 400 K:",
                  f"- refinement + exact sort ≤ 30 ms per frame, as the representation runs them (refinement "
                  f"{median(f4, 'refine', 1e3):.1f} + ordering in the write {ordering:.1f} (counted as "
                  f"{max(ordering, 0.0):.1f}) + the given order {median(f4, 'exact_sort', 1e3):.2f}): "
                  f"{refine_sort:.1f} ms (**{'met' if refine_sort <= 30 else 'not met'}**); with the sort of any "
                  f"mesh from its paths instead: {from_paths:.1f} ms ({'met' if from_paths <= 30 else 'not met'});",
                  f"- exact sort ≥ 3× faster than vtkCellCenterDepthSort (from paths, tree included): {ratio:.1f}× "
                  f"({'met' if ratio >= 3 else 'not met'});",
                  f"- image RMSE within 2× of the RMSE at 1 M: {rmse4:.2f} vs {rmse1:.2f} "
                  f"({'met' if rmse4 <= 2 * rmse1 else 'not met'})."]
    lines += ["", BEFORE]
    lines += ["", f"![frame 0 at 100 K, 400 K, 1 M tetrahedra and the full-resolution volume rendering]"
              f"(images/{os.path.basename(STRIP)})", ""]
    return lines


def strip(budgets):
    """Frame 0 at each budget beside the full-resolution rendering, left to right."""
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOImage import vtkPNGWriter

    tiles = [np.load(os.path.join(ROOT, "build", f"bench_view_{b}.npy")) for b in budgets]
    tiles.append(np.load(os.path.join(ROOT, "build", "bench_view_reference.npy")))
    row = np.concatenate(tiles, axis=1).astype(np.uint8)
    h, w, _ = row.shape
    img = vtkImageData()
    img.SetDimensions(w, h, 1)
    arr = numpy_to_vtk(row.reshape(-1, 3), deep=1)
    img.GetPointData().SetScalars(arr)
    os.makedirs(IMAGES, exist_ok=True)
    writer = vtkPNGWriter()
    writer.SetFileName(STRIP)
    writer.SetInputData(img)
    writer.Write()


def main():
    if not os.path.exists(BONSAI):
        print(f"{BONSAI} not found: skipped")
        return
    results = []
    for budget in BUDGETS:
        results.append((budget, run(budget)))
    lines = report(results)
    print("\n".join(lines))
    replace_section(HEADING, lines)
    subprocess.run(["pvpython", __file__, "--strip"], check=True)


if __name__ == "__main__":
    if "--measure" in sys.argv:
        measure(int(sys.argv[sys.argv.index("--measure") + 1]))
    elif "--strip" in sys.argv:
        strip(BUDGETS)
    else:
        main()
