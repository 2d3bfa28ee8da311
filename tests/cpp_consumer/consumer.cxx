// Uses vtkAdaptiveTetrahedra and vtkAdaptiveIsosurface from the installed Diamonds package in plain
// VTK pipelines (vtkRTAnalyticSource -> filter), and vtkMaterialInterfaceApproximation on a
// two-material image, and checks their outputs. Exits non-zero on failure.
#include "vtkAdaptiveIsosurface.h"
#include "vtkAdaptiveTetrahedra.h"
#include "vtkMaterialInterfaceApproximation.h"

#include <vtkCallbackCommand.h>
#include <vtkCellData.h>
#include <vtkCellTypes.h>
#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkCommand.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkRTAnalyticSource.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace
{
int failures = 0;

void Check(bool ok, const char* what)
{
  std::printf("%s: %s\n", ok ? "ok  " : "FAIL", what);
  failures += ok ? 0 : 1;
}

// Independent of the filter: every tetrahedron must be a VTK_TETRA.
bool OnlyTetra(vtkUnstructuredGrid* grid)
{
  for (vtkIdType c = 0; c < grid->GetNumberOfCells(); ++c)
  {
    if (grid->GetCellType(c) != VTK_TETRA)
    {
      return false;
    }
  }
  return true;
}

// Every output point is an input sample: each point-data value must equal the input's value at
// the input point found at the same position.
bool PassThroughEqual(vtkImageData* input, vtkUnstructuredGrid* output, const char* name)
{
  vtkDataArray* in = input->GetPointData()->GetArray(name);
  vtkDataArray* out = output->GetPointData()->GetArray(name);
  if (!in || !out || in->GetDataType() != out->GetDataType() ||
    in->GetNumberOfComponents() != out->GetNumberOfComponents())
  {
    return false;
  }
  for (vtkIdType p = 0; p < output->GetNumberOfPoints(); ++p)
  {
    double x[3];
    output->GetPoint(p, x);
    const vtkIdType q = input->FindPoint(x);
    if (q < 0)
    {
      return false;
    }
    double ix[3];
    input->GetPoint(q, ix);
    if (std::abs(ix[0] - x[0]) + std::abs(ix[1] - x[1]) + std::abs(ix[2] - x[2]) > 1e-9)
    {
      return false;
    }
    for (int c = 0; c < in->GetNumberOfComponents(); ++c)
    {
      if (in->GetComponent(q, c) != out->GetComponent(p, c))
      {
        return false;
      }
    }
  }
  return true;
}
}

int main()
{
  vtkNew<vtkRTAnalyticSource> source;
  source->SetWholeExtent(-16, 16, -16, 16, -16, 16); // 33^3 points
  source->Update();
  vtkImageData* image = source->GetOutput();
  // A second point array to check the pass-through of arrays the filter does not approximate.
  vtkNew<vtkFloatArray> twice;
  twice->SetName("Twice");
  twice->SetNumberOfValues(image->GetNumberOfPoints());
  vtkDataArray* rt = image->GetPointData()->GetScalars();
  for (vtkIdType i = 0; i < image->GetNumberOfPoints(); ++i)
  {
    twice->SetValue(i, static_cast<float>(2.0 * rt->GetTuple1(i)));
  }
  image->GetPointData()->AddArray(twice);

  vtkNew<vtkAdaptiveTetrahedra> filter;
  filter->SetInputData(image);
  filter->SetTolerance(4.0);
  filter->Update();
  vtkUnstructuredGrid* out = filter->GetOutput();
  const vtkIdType tets = out->GetNumberOfCells();
  std::printf("33^3 Wavelet, Tolerance 4: %lld points, %lld tetrahedra (Tetrahedralize: %d)\n",
    static_cast<long long>(out->GetNumberOfPoints()), static_cast<long long>(tets), 5 * 32 * 32 * 32);

  Check(tets > 0, "tetrahedron count > 0");
  Check(OnlyTetra(out), "only VTK_TETRA cells");
  double inBounds[6], outBounds[6];
  image->GetBounds(inBounds);
  out->GetBounds(outBounds);
  bool sameBounds = true;
  for (int i = 0; i < 6; ++i)
  {
    sameBounds = sameBounds && inBounds[i] == outBounds[i];
  }
  Check(sameBounds, "output bounds equal input bounds");
  Check(PassThroughEqual(image, out, "RTData"), "RTData passed through (equal at every point)");
  Check(PassThroughEqual(image, out, "Twice"), "Twice passed through (equal at every point)");
  Check(out->GetCellData()->GetArray("BisectionDepth") != nullptr, "cell data BisectionDepth");
  vtkDataArray* err = out->GetCellData()->GetArray("ApproximationError");
  Check(err != nullptr && err->GetRange()[1] <= 4.0, "cell data ApproximationError <= Tolerance");
  vtkDataArray* count = out->GetFieldData()->GetArray("NumberOfTetrahedra");
  Check(count != nullptr && count->GetTuple1(0) == static_cast<double>(tets),
    "field data NumberOfTetrahedra");
  Check(filter->GetNumberOfHierarchyBuilds() == 1, "one hierarchy build");
  Check(filter->GetHierarchyMemorySize() == 2 * 33 * 33 * 33,
    "HierarchyMemorySize: 2 bytes per point (the full hierarchy's error bounds)");

  // Only the query changes: re-executes, does not rebuild.
  filter->SetTolerance(16.0);
  filter->Update();
  const vtkIdType coarser = filter->GetOutput()->GetNumberOfCells();
  std::printf("Tolerance 16: %lld tetrahedra, hierarchy builds: %lld\n",
    static_cast<long long>(coarser), static_cast<long long>(filter->GetNumberOfHierarchyBuilds()));
  Check(coarser > 0 && coarser <= tets, "coarser tolerance, no more tetrahedra");
  Check(filter->GetNumberOfHierarchyBuilds() == 1, "tolerance change does not rebuild");
  // The data changes: rebuild.
  rt->Modified();
  filter->Update();
  Check(filter->GetNumberOfHierarchyBuilds() == 2, "modified array rebuilds");

  // A bad parameter: an error message, an empty output, no crash.
  std::printf("(an error about a negative Tolerance is expected next)\n");
  filter->SetTolerance(-1.0);
  filter->Update();
  Check(filter->GetOutput()->GetNumberOfCells() == 0, "negative tolerance: empty output");

  // Pieces, as in a parallel run, with one ghost level requested downstream (as ParaView's
  // parallel rendering does): each piece is meshed over its own extent only, without ghost layers,
  // so two pieces meet in exactly one plane and no tetrahedron is duplicated.
  vtkNew<vtkAdaptiveTetrahedra> pieces;
  pieces->SetInputConnection(source->GetOutputPort());
  pieces->SetTolerance(4.0);
  double pieceBounds[2][6];
  vtkIdType pieceTets = 0;
  for (int piece = 0; piece < 2; ++piece)
  {
    pieces->UpdatePiece(piece, 2, 1);
    pieces->GetOutput()->GetBounds(pieceBounds[piece]);
    pieceTets += pieces->GetOutput()->GetNumberOfCells();
    std::printf("piece %d of 2 (1 ghost level requested): bounds %g %g %g %g %g %g, %lld tetrahedra\n",
      piece, pieceBounds[piece][0], pieceBounds[piece][1], pieceBounds[piece][2],
      pieceBounds[piece][3], pieceBounds[piece][4], pieceBounds[piece][5],
      static_cast<long long>(pieces->GetOutput()->GetNumberOfCells()));
    Check(OnlyTetra(pieces->GetOutput()), "piece: only VTK_TETRA cells");
  }
  double overlap = 1.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    overlap *= std::min(pieceBounds[0][2 * axis + 1], pieceBounds[1][2 * axis + 1]) -
      std::max(pieceBounds[0][2 * axis], pieceBounds[1][2 * axis]);
  }
  Check(overlap == 0.0, "the two pieces meet in a plane (no ghost layer meshed twice)");
  source->UpdatePiece(0, 1, 0); // restore the whole extent for the checks below

  // An empty image (e.g. an empty piece of a parallel run): empty output, no error.
  vtkNew<vtkImageData> empty;
  vtkNew<vtkAdaptiveTetrahedra> onEmpty;
  onEmpty->SetInputData(empty);
  int errors = 0;
  vtkNew<vtkCallbackCommand> countErrors;
  countErrors->SetClientData(&errors);
  countErrors->SetCallback(
    [](vtkObject*, unsigned long, void* count, void*) { ++*static_cast<int*>(count); });
  onEmpty->AddObserver(vtkCommand::ErrorEvent, countErrors);
  onEmpty->Update();
  Check(errors == 0 && onEmpty->GetOutput()->GetNumberOfCells() == 0,
    "empty image: empty output, no error");

  // ---- vtkAdaptiveIsosurface on the same image.
  vtkNew<vtkAdaptiveIsosurface> iso;
  iso->SetInputConnection(source->GetOutputPort());
  iso->SetValue(0, 157.0);
  iso->SetTolerance(0.5);
  iso->Update();
  vtkPolyData* surface = iso->GetOutput(0);
  const vtkIdType triangles = surface->GetNumberOfCells();
  std::printf("Adaptive Isosurface 157, Tolerance 0.5: %lld points, %lld triangles\n",
    static_cast<long long>(surface->GetNumberOfPoints()), static_cast<long long>(triangles));
  Check(triangles > 0 && surface->GetNumberOfPolys() == triangles, "isosurface: triangles only");
  bool threeCorners = true;
  for (vtkIdType c = 0; c < triangles; ++c)
  {
    threeCorners = threeCorners && surface->GetCellType(c) == VTK_TRIANGLE;
  }
  Check(threeCorners, "isosurface: every cell a VTK_TRIANGLE");
  vtkDataArray* normals = surface->GetPointData()->GetNormals();
  bool unit = normals != nullptr && normals->GetNumberOfTuples() == surface->GetNumberOfPoints();
  for (vtkIdType p = 0; unit && p < normals->GetNumberOfTuples(); ++p)
  {
    const double* n = normals->GetTuple3(p);
    unit = std::abs(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1.0) < 1e-4;
  }
  Check(unit, "isosurface: unit point normals");
  vtkDataArray* bound = surface->GetFieldData()->GetArray("ErrorBound");
  Check(bound != nullptr && bound->GetTuple1(0) <= 0.5, "isosurface: field data ErrorBound <= Tolerance");
  vtkUnstructuredGrid* noCarriers = vtkUnstructuredGrid::SafeDownCast(iso->GetOutputDataObject(1));
  Check(noCarriers != nullptr && noCarriers->GetNumberOfCells() == 0,
    "isosurface: port 1 an empty vtkUnstructuredGrid by default");
  {
    // As vtkContourFilter: the contoured array by default (ComputeScalars), every other point
    // array interpolated (Twice = 2 RTData is twice the isovalue on the surface).
    vtkNew<vtkAdaptiveIsosurface> colored;
    if (!image->GetPointData()->GetArray("Twice"))
    {
      image->GetPointData()->AddArray(twice); // gone if the source ran again
    }
    colored->SetInputData(image);
    colored->SetValue(0, 157.0);
    colored->SetTolerance(0.5);
    colored->Update();
    vtkPolyData* s = colored->GetOutput(0);
    vtkDataArray* scalars = s->GetPointData()->GetScalars();
    vtkDataArray* interpolated = s->GetPointData()->GetArray("Twice");
    bool values = s->GetNumberOfPoints() > 0 && scalars != nullptr && interpolated != nullptr &&
      interpolated->GetNumberOfTuples() == s->GetNumberOfPoints();
    for (vtkIdType p = 0; values && p < s->GetNumberOfPoints(); ++p)
    {
      values = scalars->GetTuple1(p) == 157.0 && std::abs(interpolated->GetTuple1(p) - 314.0) < 1e-3;
    }
    Check(values, "isosurface: scalars by default and other point arrays interpolated");
  }
  iso->SetValue(0, 120.0);
  iso->GenerateCarrierTetrahedraOn();
  iso->Update();
  Check(iso->GetOutput(0)->GetNumberOfCells() > 0 && iso->GetNumberOfHierarchyBuilds() == 1,
    "isosurface: isovalue change re-extracts without a rebuild");
  vtkUnstructuredGrid* carriers = vtkUnstructuredGrid::SafeDownCast(iso->GetOutputDataObject(1));
  Check(carriers != nullptr && carriers->GetNumberOfCells() > 0 && OnlyTetra(carriers),
    "isosurface: carrier tetrahedra on port 1");
  if (carriers != nullptr)
  {
    // The isosurface error of each carrier's diamond, world units: the largest is the surface's
    // ErrorBound (within Tolerance).
    vtkDataArray* isoError = carriers->GetCellData()->GetArray("IsosurfaceError");
    vtkDataArray* surfaceBound = iso->GetOutput(0)->GetFieldData()->GetArray("ErrorBound");
    Check(isoError != nullptr && surfaceBound != nullptr &&
        isoError->GetNumberOfTuples() == carriers->GetNumberOfCells() &&
        isoError->GetRange()[0] >= 0.0 && isoError->GetRange()[1] <= 0.5 &&
        isoError->GetRange()[1] == surfaceBound->GetTuple1(0) &&
        carriers->GetCellData()->GetArray("ApproximationError") == nullptr,
      "isosurface: carrier cell data IsosurfaceError, largest = ErrorBound <= Tolerance");
  }
  // The full hierarchy's memory: the float samples it reads again (no per-diamond records) and the
  // caches of its extraction.
  Check(iso->GetNumberOfHierarchyBuilds() == 1 &&
      iso->GetHierarchyMemorySize() >= 4 * 33 * 33 * 33 &&
      iso->GetHierarchyMemorySize() ==
        static_cast<vtkIdType>(
          iso->GetOutput(0)->GetFieldData()->GetArray("HierarchyMemorySize")->GetTuple1(0)),
    "isosurface: HierarchyMemorySize = the samples and the extraction's caches, as in field data");
  std::printf("(an error about a missing isovalue is expected next)\n");
  iso->SetNumberOfContours(0);
  iso->Update();
  Check(iso->GetOutput(0)->GetNumberOfCells() == 0, "isosurface: no isovalue, empty output");

  // ---- vtkMaterialInterfaceApproximation: a ball of steel in void, 33^3 points (2^5 + 1: the finest
  // level of the diamond lattice is the grid itself, so both tolerances can always be met), density.
  vtkNew<vtkImageData> materials;
  materials->SetDimensions(33, 33, 33);
  materials->SetSpacing(0.1875, 0.1875, 0.1875);
  vtkNew<vtkFloatArray> steel;
  steel->SetName("Volume Fraction for Steel");
  vtkNew<vtkFloatArray> voidFraction;
  voidFraction->SetName("Void Volume Fraction");
  vtkNew<vtkFloatArray> density;
  density->SetName("Density");
  for (vtkIdType p = 0; p < materials->GetNumberOfPoints(); ++p)
  {
    double x[3];
    materials->GetPoint(p, x);
    const double r = std::sqrt(
      (x[0] - 2.9) * (x[0] - 2.9) + (x[1] - 3.1) * (x[1] - 3.1) + (x[2] - 2.8) * (x[2] - 2.8));
    const double f = std::min(1.0, std::max(0.0, (1.6 - r) / 0.25 + 0.5)); // one cell of mixing
    steel->InsertNextValue(static_cast<float>(f));
    voidFraction->InsertNextValue(static_cast<float>(1.0 - f));
    density->InsertNextValue(static_cast<float>(7.8 * f + 0.1 * x[2]));
  }
  materials->GetPointData()->AddArray(steel);
  materials->GetPointData()->AddArray(voidFraction);
  materials->GetPointData()->AddArray(density);
  vtkNew<vtkMaterialInterfaceApproximation> approx;
  approx->SetInputData(materials);
  approx->AddVolumeFractionArray("Volume Fraction for Steel");
  approx->AddVolumeFractionArray("Void Volume Fraction");
  approx->AddFieldArray("Density");
  approx->SetInterfaceTolerance(0.05);
  approx->SetFieldTolerance(0.5);
  approx->SetSliceOrigin(2.9, 3.1, 2.8);
  approx->SetSliceNormal(0.0, 0.0, 1.0);
  approx->Update();
  vtkUnstructuredGrid* materialTets = approx->GetOutput();
  vtkPolyData* interfaces = vtkPolyData::SafeDownCast(approx->GetOutputDataObject(1));
  vtkPolyData* slice = vtkPolyData::SafeDownCast(approx->GetOutputDataObject(2));
  std::printf("Material Interface Approximation: %lld tetrahedra, %lld interface polygons, %lld "
              "slice polygons\n",
    static_cast<long long>(materialTets->GetNumberOfCells()),
    static_cast<long long>(interfaces ? interfaces->GetNumberOfCells() : -1),
    static_cast<long long>(slice ? slice->GetNumberOfCells() : -1));
  Check(materialTets->GetNumberOfCells() > 0 && OnlyTetra(materialTets), "material: tetrahedra");
  Check(interfaces && interfaces->GetNumberOfCells() > 0, "material: interface polygons on port 1");
  Check(slice && slice->GetNumberOfCells() > 0, "material: slice polygons on port 2");
  vtkDataArray* interfaceError = materialTets->GetCellData()->GetArray("InterfaceError");
  vtkDataArray* fieldError = materialTets->GetCellData()->GetArray("FieldError");
  Check(interfaceError && interfaceError->GetRange()[1] <= 0.05 * (1 + 1e-6),
    "material: InterfaceError <= InterfaceTolerance");
  vtkDataArray* maxFieldError = materialTets->GetFieldData()->GetArray("MaximumFieldError");
  std::printf("material: FieldError max %g, MaximumFieldError %g\n",
    fieldError ? fieldError->GetRange()[1] : -1.0, maxFieldError ? maxFieldError->GetTuple1(0) : -1.0);
  Check(fieldError && fieldError->GetRange()[1] <= 0.5 * (1 + 1e-6),
    "material: FieldError <= FieldTolerance");
  Check(materialTets->GetPointData()->GetArray("Density (Steel)") != nullptr &&
      materialTets->GetPointData()->GetArray("SignedDistance Steel|Void") != nullptr,
    "material: per-material field and interface distance arrays named after the materials");
  approx->SetFieldTolerance(0.25);
  approx->Update();
  Check(approx->GetNumberOfModelBuilds() == 1 && approx->GetNumberOfRefinements() == 2,
    "material: a tolerance change refines again without rebuilding the model");
  std::printf("(an error about the volume fractions is expected next)\n");
  approx->ClearVolumeFractionArrays();
  approx->AddVolumeFractionArray("Volume Fraction for Steel");
  approx->Update();
  Check(approx->GetOutput()->GetNumberOfCells() == 0, "material: one fraction array, empty output");

  std::printf("%s: %d failure(s)\n", failures ? "FAILED" : "PASSED", failures);
  return failures ? EXIT_FAILURE : EXIT_SUCCESS;
}
