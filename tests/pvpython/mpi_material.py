"""Material Interface Approximation on a distributed image: run with

  PV_PLUGIN_PATH=$PWD/build/lib/paraview-5.11/plugins/Diamonds \
    mpiexec --allow-run-as-root -n 2 pvbatch tests/pvpython/mpi_material.py

Each rank approximates its own piece of the generated impact case (`diamonds generate --field impact`).
The script (on rank 0) fetches every rank's piece of each output port separately and checks it: its
own extent, tetrahedra only, positive volumes filling the piece's box, interface polygons and a slice,
the field tolerance met (the impact density allows it at the finest level), and the reported maximum
errors equal to the cell arrays' maxima. Pieces are not required to conform to each other (documented).
"""

import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diamonds_checks as dc  # noqa: E402
from paraview import servermanager  # noqa: E402

simple = dc.require_plugin()
ranks = servermanager.vtkProcessModule.GetProcessModule().GetNumberOfLocalPartitions()
expected = int(os.environ.get("DIAMONDS_EXPECTED_RANKS", "2"))
dc.check(ranks == expected, f"running on {ranks} MPI ranks (expected {expected})")

tmp = tempfile.mkdtemp()
impact = os.path.join(tmp, "impact.vti")
subprocess.run([dc.diamonds_binary(), "generate", impact, "--field", "impact"], check=True)
reader = simple.XMLImageDataReader(FileName=[impact])
fractions = ["Volume Fraction for Void", "Volume Fraction for Block", "Volume Fraction for Projectile"]
filt = simple.MaterialInterfaceApproximation(Input=reader, VolumeFractionArrays=fractions, FieldArrays=["Density"])
filt.InterfaceTolerance = 0.15
filt.FieldTolerance = 3.0
filt.SliceOrigin = [6.0, 6.0, -5.0]
filt.SliceNormal = [0.0, 0.0, 1.0]
filt.UpdatePipeline()

extents = []
for r in range(ranks):
    piece = servermanager.Fetch(reader, r)
    tets = servermanager.Fetch(filt, r, None, 0)
    interfaces = servermanager.Fetch(filt, r, None, 1)
    cut = servermanager.Fetch(filt, r, None, 2)
    extents.append(tuple(piece.GetExtent()))
    label = f"rank {r} piece {piece.GetExtent()}"
    print(f"{label}: {tets.GetNumberOfCells()} tetrahedra, {interfaces.GetNumberOfCells()} interface polygons, "
          f"{cut.GetNumberOfCells()} slice polygons")
    if not dc.check(tets.GetNumberOfCells() > 0, f"{label}: tetrahedra"):
        continue
    types = {tets.GetCellType(c) for c in range(tets.GetNumberOfCells())}
    dc.check(types == {10}, f"{label}: only VTK_TETRA cells ({types})")
    b = piece.GetBounds()
    box = (b[1] - b[0]) * (b[3] - b[2]) * (b[5] - b[4])
    points = dc.vtk_to_numpy(tets.GetPoints().GetData()).astype(np.float64)
    ids = dc.vtk_to_numpy(tets.GetCells().GetConnectivityArray()).reshape(-1, 4)
    x = points[ids]
    volumes = np.einsum("ij,ij->i", x[:, 1] - x[:, 0], np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 0])) / 6.0
    dc.check(volumes.min() > 0 and abs(volumes.sum() - box) < 1e-5 * box,
             f"{label}: positive volumes filling the piece's box ({volumes.sum():.6g} vs {box:.6g})")
    tb = tets.GetBounds()
    dc.check(all(abs(tb[i] - b[i]) < 1e-5 for i in range(6)), f"{label}: mesh bounds {tb} = piece bounds {b}")
    field_error = dc.vtk_to_numpy(tets.GetCellData().GetArray("FieldError"))
    interface_error = dc.vtk_to_numpy(tets.GetCellData().GetArray("InterfaceError"))
    fd = tets.GetFieldData()
    dc.check(field_error.max() <= 3.0 * (1 + 1e-6), f"{label}: FieldError ≤ 3 ({field_error.max():.4g})")
    dc.check(abs(fd.GetArray("MaximumFieldError").GetValue(0) - field_error.max()) < 1e-5 and
             abs(fd.GetArray("MaximumInterfaceError").GetValue(0) - interface_error.max()) < 1e-5,
             f"{label}: reported maxima match the cell arrays")
    dc.check(interfaces.GetNumberOfCells() > 0, f"{label}: interface polygons")
    if b[4] < -5.0 < b[5]:
        dc.check(cut.GetNumberOfCells() > 0 and abs(cut.GetBounds()[4] + 5.0) < 1e-9 and abs(cut.GetBounds()[5] + 5.0) < 1e-9,
                 f"{label}: slice polygons on the plane z = -5 ({cut.GetBounds()[4:]})")
    else:
        dc.check(cut.GetNumberOfCells() == 0, f"{label}: the plane z = -5 misses the piece: no slice polygons")
if ranks > 1:
    dc.check(len(set(extents)) == ranks, f"every rank has its own piece ({extents})")

dc.finish(f"mpi_material ({ranks} ranks)", mpi=True)
