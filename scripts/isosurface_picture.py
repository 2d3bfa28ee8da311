"""Renders the README picture: Adaptive Isosurface next to the full-resolution Contour (Flying Edges).

    xvfb-run -a pvbatch scripts/isosurface_picture.py [volume.vti isovalue] [--tolerance-percent P]

Defaults to bonsai 256^3 at isovalue 40 from ../shared/data/volumes. Writes
docs/images/adaptive-isosurface.png with each surface's triangle count in its title.
"""

import argparse
import os

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT = os.path.join(os.path.dirname(ROOT), "shared", "data", "volumes", "bonsai_256x256x256_uint8_lossy.vti")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("volume", nargs="?", default=DEFAULT)
    parser.add_argument("isovalue", nargs="?", type=float, default=40.0)
    parser.add_argument("--tolerance-percent", type=float, default=1.0, help="of the bounds diagonal (default 1)")
    parser.add_argument("--output", default=os.path.join(ROOT, "docs", "images", "adaptive-isosurface.png"))
    args = parser.parse_args()
    simple.LoadPlugin(os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds", "Diamonds.so"),
                      remote=False)
    reader = simple.XMLImageDataReader(FileName=[args.volume])
    reader.UpdatePipeline()
    array = reader.PointData.keys()[0]
    b = reader.GetDataInformation().GetBounds()
    diagonal = ((b[1] - b[0]) ** 2 + (b[3] - b[2]) ** 2 + (b[5] - b[4]) ** 2) ** 0.5

    full = simple.Contour(Input=reader, ContourBy=["POINTS", array], Isosurfaces=[args.isovalue])
    full.ComputeNormals = 1
    adaptive = simple.AdaptiveIsosurface(Input=reader)
    adaptive.ContourBy = ["POINTS", array]
    adaptive.Isosurfaces = [args.isovalue]
    adaptive.Tolerance = args.tolerance_percent / 100.0 * diagonal

    layout = simple.CreateLayout("pictures")
    views = []
    for i, (source, title) in enumerate([(full, "Contour, full resolution"),
                                         (adaptive, f"Adaptive Isosurface, {args.tolerance_percent:g} % of diagonal")]):
        view = simple.CreateView("RenderView")
        simple.AssignViewToLayout(view=view, layout=layout, hint=i)
        view.OrientationAxesVisibility = 0
        view.Background = [1, 1, 1]
        try:
            view.UseColorPaletteForBackground = 0
        except AttributeError:
            pass
        source.UpdatePipeline()
        triangles = source.GetDataInformation().GetNumberOfCells()
        display = simple.Show(source, view)
        display.ColorArrayName = ["POINTS", ""]
        display.DiffuseColor = [0.55, 0.7, 0.45]
        display.SetRepresentationType("Surface")
        text = simple.Text(Text=f"{title}: {triangles:,} triangles")
        t = simple.Show(text, view)
        t.FontSize = 13
        t.Color = [0, 0, 0]
        t.WindowLocation = "Upper Center"
        center = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
        view.CameraFocalPoint = center
        view.CameraPosition = [center[0] + 1.2 * diagonal, center[1] - 1.0 * diagonal, center[2] + 0.5 * diagonal]
        view.CameraViewUp = [0, 0, 1]
        view.CameraViewAngle = 26
        views.append(view)
    simple.AddCameraLink(views[0], views[1], "link")
    simple.SaveScreenshot(args.output, layout, ImageResolution=[1600, 800])
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
