"""Demo of the Diamonds plugin: an adaptive tetrahedral mesh of ParaView's Wavelet.

    xvfb-run -a pvbatch scripts/demo.py [--output DIR] [--tolerance T] [--size N]

Generates the Wavelet source at 65^3 points (embedded: no data file needed), runs Adaptive
Tetrahedra at Tolerance 8 (about 3 % of the data range), compares the tetrahedron count with
ParaView's Tetrahedralize, and writes
    out/demo.vtu   the adaptive mesh (all input point data + cell data BisectionDepth, ApproximationError)
    out/demo.png   a screenshot: the mesh cut open by a crinkle clip, surface with edges, coloured
                   by BisectionDepth, so the refinement inside the volume shows.
The plugin is taken from PV_PLUGIN_PATH, or else from build/ (or build/install/) of this checkout.
"""

import argparse
import os
import sys
import time

from paraview import servermanager
from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_plugin():
    if hasattr(simple, "AdaptiveTetrahedra"):
        return "PV_PLUGIN_PATH"
    for tree in ("build", os.path.join("build", "install")):
        path = os.path.join(ROOT, tree, "lib", "paraview-5.11", "plugins", "Diamonds", "Diamonds.so")
        if os.path.exists(path):
            simple.LoadPlugin(path, remote=False)  # adds the filter to paraview.simple
            return path
    sys.exit("Diamonds.so not found: run `bash scripts/setup.sh` first, or set PV_PLUGIN_PATH.")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--output", default=os.path.join(ROOT, "out"), help="output folder (default: out/)")
    parser.add_argument("--tolerance", type=float, default=8.0, help="Tolerance in data units (default 8)")
    parser.add_argument("--size", type=int, default=65, help="points per axis of the Wavelet (default 65)")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)
    print(f"plugin: {load_plugin()}")

    half = (args.size - 1) // 2
    wavelet = simple.Wavelet()
    wavelet.WholeExtent = [-half, args.size - 1 - half] * 3
    wavelet.UpdatePipeline()
    lo, hi = wavelet.PointData["RTData"].GetRange()
    points = args.size**3
    print(f"input: Wavelet {args.size}^3 = {points} points, RTData range [{lo:.2f}, {hi:.2f}]")

    adaptive = simple.AdaptiveTetrahedra(Input=wavelet)
    adaptive.Scalars = ["POINTS", "RTData"]
    adaptive.Tolerance = args.tolerance
    t0 = time.time()
    adaptive.UpdatePipeline()
    t_build = time.time() - t0
    mesh = servermanager.Fetch(adaptive)
    n_adaptive = mesh.GetNumberOfCells()
    max_error = mesh.GetFieldData().GetArray("MaximumError").GetValue(0)

    tetrahedralize = simple.Tetrahedralize(Input=wavelet)
    t0 = time.time()
    tetrahedralize.UpdatePipeline()
    t_tetra = time.time() - t0
    n_full = tetrahedralize.GetDataInformation().GetNumberOfCells()

    # Only the query changes: no rebuild of the hierarchy.
    adaptive.Tolerance = 2.0 * args.tolerance
    t0 = time.time()
    adaptive.UpdatePipeline()
    t_query = time.time() - t0
    n_coarser = adaptive.GetDataInformation().GetNumberOfCells()
    adaptive.Tolerance = args.tolerance
    adaptive.UpdatePipeline()

    print(f"Adaptive Tetrahedra, Tolerance {args.tolerance:g}: {n_adaptive} tetrahedra, "
          f"{mesh.GetNumberOfPoints()} points, max error {max_error:.3f}  ({t_build:.2f} s incl. hierarchy)")
    print(f"Tetrahedralize:                   {n_full} tetrahedra  ({t_tetra:.2f} s)")
    print(f"ratio: {n_adaptive / n_full:.3f} of Tetrahedralize's tetrahedra ({n_full / n_adaptive:.1f}x fewer)")
    print(f"Tolerance {2 * args.tolerance:g} (query only, cached hierarchy): {n_coarser} tetrahedra ({t_query:.3f} s)")

    vtu = os.path.join(args.output, "demo.vtu")
    simple.SaveData(vtu, proxy=adaptive)
    print(f"wrote {vtu}")

    # The picture: cut the mesh open with whole cells kept (crinkle clip) to show the interior.
    clip = simple.Clip(Input=adaptive)
    clip.ClipType = "Plane"
    clip.ClipType.Origin = [0.0, 0.0, 0.0]
    clip.ClipType.Normal = [1.0, -0.6, 0.5]
    clip.Crinkleclip = 1
    view = simple.CreateView("RenderView")
    view.ViewSize = [1400, 1000]
    view.Background = [1.0, 1.0, 1.0]
    view.OrientationAxesVisibility = 0
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    display = simple.Show(clip, view)
    display.SetRepresentationType("Surface With Edges")
    display.EdgeColor = [0.15, 0.15, 0.15]
    simple.ColorBy(display, ("CELLS", "BisectionDepth"))
    lut = simple.GetColorTransferFunction("BisectionDepth")
    lut.ApplyPreset("Viridis (matplotlib)", True)
    levels = mesh.GetCellData().GetArray("BisectionDepth").GetRange()
    lut.RescaleTransferFunction(levels[0], levels[1])
    lut.Discretize = 1
    lut.NumberOfTableValues = max(1, int(levels[1] - levels[0]) + 1)
    bar = simple.GetScalarBar(lut, view)
    bar.Title = "Bisection depth"
    bar.ComponentTitle = ""
    bar.AutomaticLabelFormat = 0
    bar.LabelFormat = "%.0f"
    bar.RangeLabelFormat = "%.0f"
    bar.UseCustomLabels = 1
    bar.CustomLabels = list(range(int(levels[0]), int(levels[1]) + 1))
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
    bar.Visibility = 1
    outline = simple.Show(simple.Outline(Input=wavelet), view)
    outline.DiffuseColor = outline.AmbientColor = [0.2, 0.2, 0.2]
    text = simple.Text(
        Text=f"Adaptive Tetrahedra, Wavelet {args.size}^3, Tolerance {args.tolerance:g}: "
        f"{n_adaptive} tetrahedra (Tetrahedralize: {n_full})"
    )
    text_display = simple.Show(text, view)
    text_display.Color = [0.1, 0.1, 0.1]
    text_display.FontSize = 14
    text_display.WindowLocation = "Upper Center"
    view.CameraPosition = [95.0, -70.0, 75.0]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.ResetCamera()
    simple.Render(view)
    png = os.path.join(args.output, "demo.png")
    simple.SaveScreenshot(png, view, ImageResolution=[1400, 1000])
    print(f"wrote {png}")


main()
