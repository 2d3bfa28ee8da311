"""Renders the README picture of Material Interface Approximation on the generated impact analogue:
the density on a cut through the impact axis with plain linear interpolation (left) and with one field
per material and ghost values (right), both at density tolerance 3, with the tetrahedra's edges on the cut
and the approximated interfaces (the paper's Figures 15 and 16).

    xvfb-run -a pvbatch scripts/material_picture.py

Needs the build (bash scripts/setup.sh) and the CLI (cargo build --release -p diamonds-cli). Writes
docs/images/material-interface.png.
"""

import os
import subprocess
import tempfile

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PLUGIN = os.path.join(ROOT, "build", "lib", "paraview-5.11", "plugins", "Diamonds", "Diamonds.so")
CLI = os.path.join(ROOT, "target", "release", "diamonds")
OUTPUT = os.path.join(ROOT, "docs", "images", "material-interface.png")


def main():
    simple.LoadPlugin(PLUGIN, remote=False)
    tmp = tempfile.mkdtemp()
    impact = os.path.join(tmp, "impact.vti")
    subprocess.run([CLI, "generate", "--field", "impact", impact], check=True)
    reader = simple.XMLImageDataReader(FileName=[impact])
    reader.UpdatePipeline()
    fractions = [a for a in reader.PointData.keys() if "Fraction" in a]
    layout = simple.CreateLayout("pictures")
    views = []
    lut = simple.GetColorTransferFunction("Density")
    lut.ApplyPreset("Viridis (matplotlib)", True)
    lut.RescaleTransferFunction(0.0, 20.0)
    for i, ghost in enumerate([False, True]):
        f = simple.MaterialInterfaceApproximation(Input=reader)
        f.VolumeFractionArrays = fractions
        f.FieldArrays = ["Density"]
        f.InterfaceTolerance = 0.15
        f.FieldTolerance = 3.0
        f.UseGhostValues = 1 if ghost else 0
        f.SliceOrigin = [0.3, 0.3, 0.0]
        f.SliceNormal = [1.0, -1.0, 0.0]  # through the impact axis, along the diagonal
        f.UpdatePipeline()
        tets = f.GetDataInformation().GetNumberOfCells()
        view = simple.CreateView("RenderView")
        simple.AssignViewToLayout(view=view, layout=layout, hint=i)
        view.OrientationAxesVisibility = 0
        view.Background = [1, 1, 1]
        try:
            view.UseColorPaletteForBackground = 0
        except AttributeError:
            pass
        cut = simple.OutputPort(f, 2)
        display = simple.Show(cut, view)
        simple.ColorBy(display, ("POINTS", "Density"))
        display.LookupTable = lut
        # The tetrahedra's edges on the cut plane.
        section = simple.Slice(Input=f)
        section.SliceType = "Plane"
        section.SliceType.Origin = [0.3, 0.3, 0.0]
        section.SliceType.Normal = [1.0, -1.0, 0.0]
        wire = simple.Show(section, view)
        wire.SetRepresentationType("Wireframe")
        wire.ColorArrayName = ["POINTS", ""]
        wire.AmbientColor = wire.DiffuseColor = [0.85, 0.85, 0.85]
        wire.Opacity = 0.35
        title = (
            f"One field per material with ghost values: {tets:,} tetrahedra"
            if ghost
            else f"Plain linear interpolation: {tets:,} tetrahedra"
        )
        text = simple.Show(simple.Text(Text=title + "\n(density tolerance 3, cut through the impact axis)"), view)
        text.FontSize = 13
        text.Color = [0, 0, 0]
        text.WindowLocation = "Upper Center"
        view.CameraFocalPoint = [6.0, 6.0, -5.6]
        view.CameraPosition = [6.0 + 38.0, 6.0 - 38.0, -5.6]  # looking along the cut's normal
        view.CameraViewUp = [0, 0, 1]
        view.CameraViewAngle = 30
        views.append(view)
    bar = simple.GetScalarBar(lut, views[1])
    bar.Title = "Density"
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0, 0, 0]
    bar.Visibility = 1
    simple.AddCameraLink(views[0], views[1], "link")
    simple.SaveScreenshot(OUTPUT, layout, ImageResolution=[1600, 800])
    print(f"wrote {OUTPUT}")


if __name__ == "__main__":
    main()
