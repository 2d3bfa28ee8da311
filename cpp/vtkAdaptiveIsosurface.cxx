#include "vtkAdaptiveIsosurface.h"

#include "vtkCellArray.h"
#include "vtkContourValues.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge. Kept out of the public header: the VTK
// wrappers parse that one.
#include "vtkDiamondsArraySelection.h"
#include "vtkDiamondsHierarchyCache.h"
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsOutput.h"
#include "vtkDiamondsPieces.h"
#include "vtkDiamondsProgress.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>


vtkStandardNewMacro(vtkAdaptiveIsosurface);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::FixedSizeCells;
using vtkDiamonds::NamedArray;
using vtkDiamonds::OneValue;

const vtkDiamonds::FilterText Text = { "Adaptive Isosurface", "contour", "contours",
  "Contour By" };
} // namespace

class vtkAdaptiveIsosurface::vtkInternals
{
public:
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
  // The extraction reads the samples again: keep them with the hierarchy.
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Isosurfaces };

  // The isovalues, once they, Tolerance and MaximumNumberOfTriangles are checked.
  std::optional<std::vector<double>> CheckParameters(vtkAdaptiveIsosurface* self);
  // The surface as points, triangles, every other point array of `in` (the input's point data)
  // interpolated as vtkContourFilter does and, when asked for, normals and scalars (of `array`'s
  // type).
  void FillSurface(vtkAdaptiveIsosurface* self, const bridge::Surface& surface,
    vtkDataArray* array, vtkPointData* in, rust::Slice<const std::uint32_t> sources,
    vtkPolyData* output);
  // The extraction's parameters (tolerance, budget, outputs; not the region of interest).
  bridge::IsoSpec Spec(vtkAdaptiveIsosurface* self) const;

  // On more than one rank: the whole image this rank put together.
  vtkDiamonds::WholeImage Whole;
};

//------------------------------------------------------------------------------
bridge::IsoSpec vtkAdaptiveIsosurface::vtkInternals::Spec(vtkAdaptiveIsosurface* self) const
{
  bridge::IsoSpec spec;
  spec.tolerance = self->Tolerance;
  spec.max_triangles = static_cast<std::size_t>(self->MaximumNumberOfTriangles);
  spec.compute_normals = self->ComputeNormals != 0;
  spec.carrier_tetrahedra = self->GenerateCarrierTetrahedra != 0;
  return spec;
}

//------------------------------------------------------------------------------
vtkAdaptiveIsosurface::vtkAdaptiveIsosurface()
  : ContourValues(vtkContourValues::New())
  , Tolerance(0.0)
  , RelativeTolerance(0.0)
  , MaximumNumberOfTriangles(0)
  , UseRegionOfInterest(0)
  , RegionOfInterest{ 0.0, 1.0, 0.0, 1.0, 0.0, 1.0 }
  , ComputeNormals(1)
  , ComputeScalars(1)
  , GenerateCarrierTetrahedra(0)
  , Hierarchy(HIERARCHY_FULL)
  , NumberOfHierarchyBuilds(0)
  , NumberOfIsodiamondBuilds(0)
  , NumberOfReusedMeshes(0)
  , Internals(new vtkInternals)
{
  this->SetNumberOfOutputPorts(2);
  // Default: the active point scalars.
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkAdaptiveIsosurface::~vtkAdaptiveIsosurface()
{
  this->ContourValues->Delete();
  delete this->Internals;
}

//------------------------------------------------------------------------------
vtkMTimeType vtkAdaptiveIsosurface::GetMTime()
{
  return std::max(this->Superclass::GetMTime(), this->ContourValues->GetMTime());
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::SetValue(int i, double value)
{
  this->ContourValues->SetValue(i, value);
}

double vtkAdaptiveIsosurface::GetValue(int i)
{
  return this->ContourValues->GetValue(i);
}

double* vtkAdaptiveIsosurface::GetValues()
{
  return this->ContourValues->GetValues();
}

void vtkAdaptiveIsosurface::SetNumberOfContours(int number)
{
  this->ContourValues->SetNumberOfContours(number);
}

vtkIdType vtkAdaptiveIsosurface::GetNumberOfContours()
{
  return this->ContourValues->GetNumberOfContours();
}

void vtkAdaptiveIsosurface::GenerateValues(int numContours, double rangeStart, double rangeEnd)
{
  this->ContourValues->GenerateValues(numContours, rangeStart, rangeEnd);
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::FillOutputPortInformation(int port, vtkInformation* info)
{
  // Port 0: the isosurface; port 1: the tetrahedra carrying it.
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkPolyData" : "vtkUnstructuredGrid");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::RequestUpdateExtent(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  if (!this->Superclass::RequestUpdateExtent(request, inputVector, outputVector))
  {
    return 0;
  }
  vtkDiamonds::RequestNoGhostLevels(inputVector);
  return 1;
}

//------------------------------------------------------------------------------
vtkIdType vtkAdaptiveIsosurface::GetHierarchyMemorySize()
{
  return this->Internals->Cache.GetMemorySize();
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::ReleaseHierarchy()
{
  this->Internals->Cache.Release();
}

//------------------------------------------------------------------------------
std::optional<std::vector<double>> vtkAdaptiveIsosurface::vtkInternals::CheckParameters(
  vtkAdaptiveIsosurface* self)
{
  vtkContourValues* contours = self->ContourValues;
  const int numValues = static_cast<int>(contours->GetNumberOfContours());
  if (numValues < 1)
  {
    vtkErrorWithObjectMacro(
      self, << "No isovalue: add at least one value to Isosurfaces (SetValue).");
    return std::nullopt;
  }
  std::vector<double> isovalues(contours->GetValues(), contours->GetValues() + numValues);
  for (int i = 0; i < numValues; ++i)
  {
    if (!std::isfinite(isovalues[i]))
    {
      vtkErrorWithObjectMacro(self,
        << "Isosurfaces value " << i << " is " << isovalues[i]
        << "; every isovalue must be a finite number.");
      return std::nullopt;
    }
  }
  if (!std::isfinite(self->Tolerance) || self->Tolerance < 0.0)
  {
    vtkErrorWithObjectMacro(self,
      << "Tolerance must be a finite number >= 0 (got " << self->Tolerance
      << "); it is in world units, 0 gives the full-resolution surface.");
    return std::nullopt;
  }
  if (self->MaximumNumberOfTriangles < 0)
  {
    vtkErrorWithObjectMacro(self,
      << "MaximumNumberOfTriangles must be >= 0 (got " << self->MaximumNumberOfTriangles
      << "); 0 means no limit.");
    return std::nullopt;
  }
  return isovalues;
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::vtkInternals::FillSurface(vtkAdaptiveIsosurface* self,
  const bridge::Surface& surface, vtkDataArray* array, vtkPointData* in,
  rust::Slice<const std::uint32_t> sources, vtkPolyData* output)
{
  const rust::Slice<const std::uint32_t> triangles = surface.triangles();
  const rust::Slice<const double> values = surface.values();
  const vtkIdType numPoints = static_cast<vtkIdType>(values.size());
  vtkSmartPointer<vtkPoints> points = vtkDiamonds::PointsFrom(surface.points());
  output->SetPoints(points);
  output->SetPolys(FixedSizeCells(3, triangles, numPoints));
  // The contoured array is the isovalue there: ComputeScalars writes it exactly, or leaves it out.
  // The normals and scalars below are added, then made active: SetNormals or SetScalars would
  // replace an interpolated array that holds that role in the input (a Calculator's result).
  vtkDiamonds::InterpolatePointData(
    in, array->GetName(), sources, surface.weights(), output->GetPointData());
  if (self->ComputeNormals)
  {
    const rust::Slice<const float> normals = surface.normals();
    vtkNew<vtkFloatArray> normalArray;
    normalArray->SetName("Normals");
    normalArray->SetNumberOfComponents(3);
    vtkDiamonds::Allocate(normalArray, 3 * numPoints);
    std::copy(normals.begin(), normals.end(), normalArray->GetPointer(0));
    output->GetPointData()->SetActiveAttribute(
      output->GetPointData()->AddArray(normalArray), vtkDataSetAttributes::NORMALS);
  }
  if (self->ComputeScalars)
  {
    // Of the input array's type, as vtkFlyingEdges3D does.
    vtkSmartPointer<vtkDataArray> scalars =
      vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(array->GetDataType()));
    scalars->SetName(array->GetName());
    scalars->SetNumberOfComponents(1);
    vtkDiamonds::Allocate(scalars, numPoints);
    for (vtkIdType i = 0; i < numPoints; ++i)
    {
      scalars->SetComponent(i, 0, values[i]);
    }
    output->GetPointData()->SetActiveAttribute(
      output->GetPointData()->AddArray(scalars), vtkDataSetAttributes::SCALARS);
  }
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkPolyData* output = vtkPolyData::GetData(outputVector, 0);
  vtkUnstructuredGrid* carrier = vtkUnstructuredGrid::GetData(outputVector, 1);
  if (!input || !output || !carrier)
  {
    vtkErrorMacro(<< "Adaptive Isosurface needs a vtkImageData input.");
    return 0;
  }
  // Every error below leaves empty outputs.
  output->Initialize();
  carrier->Initialize();
  this->RelativeTolerance = 0.0;
  if (vtkMultiProcessController* controller = vtkDiamonds::Pieces::DistributedController())
  {
    return this->RequestDistributed(controller, inputVector, input, output, carrier);
  }

  // ---- Parameters, geometry, the array to contour.
  const std::optional<std::vector<double>> isovalues = this->Internals->CheckParameters(this);
  if (!isovalues)
  {
    return 0;
  }
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
  int result = 0;
  vtkDataArray* array =
    vtkDiamonds::ImageArrayToProcess(this, Text, input, selected, association, result);
  if (!array)
  {
    return result;
  }
  const double diagonal = vtkDiamonds::WholeDiagonal(inputVector, input);
  const double relativeTolerance = diagonal > 0.0 ? this->Tolerance / diagonal : 0.0;

  // ---- Hierarchy: built only when the array or the geometry changed.
  vtkDiamonds::HierarchyCache& cache = this->Internals->Cache;
  if (!cache.Prepare(this, Text, input, array, 0.0, 0.7, this->NumberOfHierarchyBuilds, result))
  {
    return result;
  }

  // ---- The isodiamond hierarchy of the one isovalue (Relevant, Minimal), kept while the value,
  // the choice and the input stay; dropped with Full.
  const bridge::Isodiamonds* isodiamonds = nullptr;
  if (this->Hierarchy != HIERARCHY_FULL)
  {
    if (isovalues->size() != 1)
    {
      vtkErrorMacro(<< "Hierarchy " << (this->Hierarchy == HIERARCHY_MINIMAL ? "Minimal" : "Relevant")
                    << " encodes one isosurface, but " << isovalues->size()
                    << " contour values are set: keep one value, or choose Hierarchy Full.");
      return 0;
    }
    // Options its extraction refuses are refused before the build, not after it.
    try
    {
      bridge::check_isodiamond_query(
        this->UseRegionOfInterest != 0, this->GenerateCarrierTetrahedra != 0);
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< Text.Name << ", Hierarchy "
                    << (this->Hierarchy == HIERARCHY_MINIMAL ? "Minimal" : "Relevant") << ": "
                    << e.what());
      return 0;
    }
    isodiamonds = cache.PrepareIsodiamonds(this, Text, *isovalues,
      this->Hierarchy == HIERARCHY_MINIMAL, 0.7, 0.75, this->NumberOfIsodiamondBuilds, result);
    if (!isodiamonds)
    {
      return result;
    }
  }
  else
  {
    cache.ReleaseIsodiamonds();
  }
  this->UpdateProgress(0.75);

  // ---- Extraction. The cache's isosurface state belongs to its hierarchy (recreated with every
  // build): the adaptive mesh of the previous execution is reused when only ComputeNormals,
  // ComputeScalars or GenerateCarrierTetrahedra changed; otherwise it is refined from the root.
  // An isodiamond hierarchy reads no sample.
  bridge::IsoSpec spec = this->Internals->Spec(this);
  if (!vtkDiamonds::SetRegionOfInterest(
        this, this->UseRegionOfInterest, this->RegionOfInterest, inputVector, input, spec))
  {
    return 0;
  }
  std::optional<rust::Box<bridge::Surface>> surface;
  try
  {
    const rust::Slice<const double> values(isovalues->data(), isovalues->size());
    surface.emplace(isodiamonds
        ? isodiamonds->isosurface(values, spec)
        : cache.GetHierarchy().isosurface(
            cache.GetIsoState(), cache.GetSampleType(), cache.GetSamples(), values, spec));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Isosurface extraction failed for array \"" << array->GetName()
                  << "\": " << e.what());
    return 0;
  }
  try
  {
    for (const rust::String& warning : (*surface)->warnings())
    {
      vtkWarningMacro(<< "Adaptive Isosurface, array \"" << array->GetName()
                      << "\": " << std::string(warning));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Isosurface: " << e.what());
    return 0;
  }
  if (!isodiamonds && cache.GetIsoState().reused())
  {
    ++this->NumberOfReusedMeshes;
  }
  this->UpdateProgress(0.9);
  if (this->CheckAbort())
  {
    return 1;
  }

  // ---- Output port 0: the surface.
  this->Internals->FillSurface(
    this, **surface, array, input->GetPointData(), (*surface)->sources(), output);
  this->RelativeTolerance = relativeTolerance;
  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkDoubleArray>("ErrorBound", (*surface)->error_bound()));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTriangles", output->GetNumberOfCells()));
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RelativeTolerance", relativeTolerance));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("HierarchyMemorySize", cache.GetMemorySize()));
  if (isodiamonds)
  {
    const rust::Slice<const double> ladder = isodiamonds->ladder();
    fieldData->AddArray(NamedArray<vtkDoubleArray>(
      "HierarchyLadder", static_cast<vtkIdType>(ladder.size()), ladder.data()));
  }

  // ---- Output port 1: the tetrahedra carrying the surface.
  if (this->GenerateCarrierTetrahedra)
  {
    std::optional<rust::Box<bridge::Mesh>> mesh;
    try
    {
      mesh.emplace((*surface)->take_carrier());
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< e.what());
      output->Initialize();
      return 0;
    }
    vtkDiamonds::MeshToUnstructuredGrid(**mesh, input, "IsosurfaceError", carrier);
    carrier->GetFieldData()->AddArray(
      OneValue<vtkIdTypeArray>("NumberOfTetrahedra", carrier->GetNumberOfCells()));
    carrier->GetFieldData()->AddArray(OneValue<vtkDoubleArray>("MaximumError", (*mesh)->max_error()));
  }

  this->UpdateProgress(1.0);
  return 1;
}
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "Adaptive Isosurface", outputVector, e);
  return 0;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::RequestDistributed(vtkMultiProcessController* controller,
  vtkInformationVector** inputVector, vtkImageData* input, vtkPolyData* output,
  vtkUnstructuredGrid* carrier)
{
  const auto started = std::chrono::steady_clock::now();
  const bool empty = input->GetNumberOfPoints() == 0;
  // Every rank takes part in every collective step below; a failure on one rank is agreed on
  // before the next one. Each step between two collective ones runs in Pieces::Run: whatever fails
  // on this rank (out of memory among it) is reported here and agreed on, so that all ranks leave
  // together with empty outputs.
  vtkDiamonds::Pieces pieces(controller, inputVector[0]->GetInformationObject(0), input);
  const auto run = [&](const char* failure, auto&& work) {
    return vtkDiamonds::Pieces::Run(this, Text.Name, failure, work);
  };
  const auto agree = [&](bool mine, const char* what) {
    if (pieces.Agree(this, Text.Name, mine, what))
    {
      return true;
    }
    output->Initialize();
    carrier->Initialize();
    return false;
  };

  // ---- Parameters and this piece's samples (an empty piece reads no array).
  const std::optional<std::vector<double>> isovalues = this->Internals->CheckParameters(this);
  bridge::IsoSpec spec = this->Internals->Spec(this);
  spec.use_region_of_interest = this->UseRegionOfInterest != 0;
  std::copy(this->RegionOfInterest, this->RegionOfInterest + 6, spec.region_of_interest.begin());
  vtkDataArray* array = nullptr;
  vtkSmartPointer<vtkDataArray> samples;
  bridge::ScalarType type = bridge::ScalarType::F64;
  bool ok = isovalues.has_value();
  if (ok && this->Hierarchy != HIERARCHY_FULL)
  {
    vtkErrorMacro(<< "Hierarchy Relevant and Minimal run on one process: choose Hierarchy Full "
                     "for distributed (MPI) execution.");
    ok = false;
  }
  if (ok && !empty)
  {
    ok = run("cannot read its input", [&] {
      int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
      vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
      return vtkDiamonds::CheckAxisAligned(this, Text, input) &&
        (array = vtkDiamonds::SelectPointArray(this, Text, input, selected, association)) &&
        vtkDiamonds::CoreSamples(this, Text, array, samples, type);
    });
  }
  if (!agree(ok, "reading the input"))
  {
    return pieces.Failed();
  }

  // ---- The whole image of the processed array on every rank with a piece, fetched again when
  // any rank's input changed (keyed by the array as read; its converted samples are gathered).
  // The other point arrays are not: the output fetches them at its points' sources only.
  const vtkDiamonds::WholeImage::Key key = vtkDiamonds::WholeImage::KeyOf(pieces, input, array);
  if (this->Internals->Whole.Stale(pieces, key))
  {
    this->Internals->Cache.Release();
    if (!this->Internals->Whole.Gather(this, Text.Name, pieces, input, samples, key))
    {
      output->Initialize();
      carrier->Initialize();
      return pieces.Failed();
    }
  }
  this->UpdateProgress(0.1);

  // ---- This rank's share of the surface of the whole image.
  vtkImageData* whole = this->Internals->Whole.Get();
  vtkDiamonds::HierarchyCache& cache = this->Internals->Cache;
  std::optional<rust::Box<bridge::Surface>> surface;
  if (whole)
  {
    const std::string failed =
      std::string("extraction failed for array \"") + array->GetName() + "\"";
    ok = run(failed.c_str(), [&] {
      int result = 0; // the agreement below decides what to return
      if (!cache.Prepare(this, Text, whole, whole->GetPointData()->GetScalars(), 0.1, 0.7,
            this->NumberOfHierarchyBuilds, result))
      {
        return false;
      }
      // The ranks share the bound's check: each checks what it owns and they exchange the
      // violations of every round (a rank without a piece takes part from its next Agree).
      vtkDiamonds::SharedStep exchange(pieces, this, Text.Name);
      try
      {
        surface.emplace(cache.GetHierarchy().isosurface_piece(cache.GetIsoState(),
          cache.GetSampleType(), cache.GetSamples(),
          rust::Slice<const double>(isovalues->data(), isovalues->size()), spec,
          pieces.Extents(), static_cast<std::size_t>(pieces.Rank()), exchange));
      }
      catch (const rust::Error&)
      {
        if (pieces.Stopped())
        {
          return false; // agreed on and reported in the exchange
        }
        throw;
      }
      for (const rust::String& warning : (*surface)->warnings())
      {
        vtkWarningMacro(<< "Adaptive Isosurface, array \"" << array->GetName()
                        << "\": " << std::string(warning));
      }
      return true;
    });
    if (!ok)
    {
      surface.reset();
    }
  }
  if (!agree(ok, "the extraction"))
  {
    // Ranks that completed the extraction (or its error measurement) keep its mesh (or errors),
    // the others not: cleared on all, so that the next extraction starts alike on every rank and
    // they exchange alike.
    cache.ClearIsosurfaceState();
    return pieces.Failed();
  }
  if (surface && cache.GetIsoState().reused())
  {
    ++this->NumberOfReusedMeshes;
  }
  this->UpdateProgress(0.85);

  // ---- The point data of this rank's points (the sources of the surface's points, the carrier
  // tetrahedra's points): from its piece, or fetched from the ranks holding them. The contoured
  // array only for the carriers (the surface's points hold the isovalues).
  std::optional<rust::Box<bridge::PointSources>> sources;
  ok = !surface || run("could not find where its point data comes from", [&] {
    sources.emplace((*surface)->piece_sources(pieces.Whole(), pieces.OwnExtent()));
    return true;
  });
  vtkNew<vtkPointData> table;
  ok = pieces.SourceTable(this, Text.Name, ok && sources ? &**sources : nullptr,
         empty ? nullptr : input->GetPointData(),
         this->GenerateCarrierTetrahedra ? nullptr : array, table) &&
    ok;
  if (!agree(ok, "fetching point data"))
  {
    return pieces.Failed();
  }
  this->UpdateProgress(0.9);

  // ---- Output: this rank's triangles with global point ids, and its carrier tetrahedra.
  std::vector<double> errorBound{ 0.0 };
  ok = !surface || run("could not write its output", [&] {
    const rust::Slice<const std::uint32_t> rows = (*sources)->rows();
    const std::size_t onSurface = (*surface)->sources().size();
    this->Internals->FillSurface(
      this, **surface, array, table, { rows.data(), onSurface }, output);
    output->GetPointData()->SetGlobalIds(vtkDiamonds::GlobalPointIds((*surface)->global_point_ids()));
    errorBound[0] = (*surface)->error_bound();
    if (this->GenerateCarrierTetrahedra)
    {
      rust::Box<bridge::Mesh> mesh = (*surface)->take_carrier();
      vtkDiamonds::MeshToUnstructuredGrid(*mesh, whole, "IsosurfaceError", carrier, table,
        { rows.data() + onSurface, rows.size() - onSurface });
      carrier->GetFieldData()->AddArray(
        OneValue<vtkIdTypeArray>("NumberOfTetrahedra", carrier->GetNumberOfCells()));
      carrier->GetFieldData()->AddArray(OneValue<vtkDoubleArray>("MaximumError", mesh->max_error()));
    }
    return true;
  });
  surface.reset();
  sources.reset();
  if (!agree(ok, "the output"))
  {
    return pieces.Failed();
  }
  const vtkIdType numTriangles = output->GetNumberOfCells();
  std::string error;
  if (!pieces.MaxInPlace(errorBound, error))
  {
    vtkErrorMacro(<< "Adaptive Isosurface could not combine the ranks' error bounds: " << error);
    output->Initialize();
    carrier->Initialize();
    return 0;
  }
  const vtkIdType total = pieces.Sum(numTriangles);
  const double diagonal = pieces.WholeDiagonal();
  const double relativeTolerance = diagonal > 0.0 ? this->Tolerance / diagonal : 0.0;
  this->RelativeTolerance = relativeTolerance;
  vtkFieldData* fieldData = output->GetFieldData();
  if (!empty)
  {
    fieldData->PassData(input->GetFieldData());
  }
  fieldData->AddArray(OneValue<vtkDoubleArray>("ErrorBound", errorBound[0]));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTriangles", total));
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RelativeTolerance", relativeTolerance));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("HierarchyMemorySize", cache.GetMemorySize()));
  pieces.AddFigures(fieldData, "TrianglesPerRank", numTriangles, started);
  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  this->ContourValues->PrintSelf(os, indent.GetNextIndent());
  os << indent << "Tolerance: " << this->Tolerance << "\n";
  os << indent << "RelativeTolerance: " << this->RelativeTolerance << "\n";
  os << indent << "MaximumNumberOfTriangles: " << this->MaximumNumberOfTriangles << "\n";
  os << indent << "UseRegionOfInterest: " << (this->UseRegionOfInterest ? "On" : "Off") << "\n";
  os << indent << "RegionOfInterest: (" << this->RegionOfInterest[0] << ", "
     << this->RegionOfInterest[1] << ", " << this->RegionOfInterest[2] << ", "
     << this->RegionOfInterest[3] << ", " << this->RegionOfInterest[4] << ", "
     << this->RegionOfInterest[5] << ")\n";
  os << indent << "ComputeNormals: " << (this->ComputeNormals ? "On" : "Off") << "\n";
  os << indent << "ComputeScalars: " << (this->ComputeScalars ? "On" : "Off") << "\n";
  os << indent << "GenerateCarrierTetrahedra: " << (this->GenerateCarrierTetrahedra ? "On" : "Off")
     << "\n";
  os << indent << "Hierarchy: "
     << (this->Hierarchy == HIERARCHY_FULL ? "Full"
                                             : this->Hierarchy == HIERARCHY_RELEVANT ? "Relevant"
                                                                                     : "Minimal")
     << "\n";
  os << indent << "NumberOfHierarchyBuilds: " << this->NumberOfHierarchyBuilds << "\n";
  os << indent << "NumberOfIsodiamondBuilds: " << this->NumberOfIsodiamondBuilds << "\n";
  os << indent << "NumberOfReusedMeshes: " << this->NumberOfReusedMeshes << "\n";
  os << indent << "HierarchyMemorySize: " << this->GetHierarchyMemorySize() << "\n";
}
